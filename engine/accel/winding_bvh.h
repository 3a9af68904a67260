#pragma once
// WindingBvh: the generalized winding number of one triangle mesh at many points, fast.
//
// Barill, Dickson, Schmidt, Levin & Jacobson, "Fast Winding Numbers for Soups and Clouds",
// SIGGRAPH 2018. The winding number w(q) = Σ_i Ω_i(q)/4π (Jacobson et al. 2013; solid angles in
// geometry/solid_angle.h) is a sum of dipole fields: w(q) = (1/4π) Σ_i ∫_Ti f(x)·n_i dA with
// f(x) = (x − q)/|x − q|³. A BVH groups the triangles; for a node whose triangles all lie within
// radius r of their area-weighted centre p̃, a point q with |q − p̃| > β·r sees the node through
// the Taylor expansion of f about p̃ (Barill et al. §3.2) to second order, as their
// implementation does:
//   w ≈ (1/4π) [ N·f + Σ_jk J_jk M_jk + ½ Σ_jkl H_jkl T_jkl ],   r⃗ = p̃ − q, ρ = |r⃗|,
//   f = r⃗/ρ³,  J_jk = δ_jk/ρ³ − 3 r_j r_k/ρ⁵,
//   H_jkl = −3 (δ_jk r_l + δ_jl r_k + δ_kl r_j)/ρ⁵ + 15 r_j r_k r_l/ρ⁷,
// with the node's moments, exact for flat triangles (n_i constant over triangle i, centroid c_i):
//   N = Σ a_i n_i (its vector area, the dipole moment),
//   M_jk = Σ a_i n_ij (c_i − p̃)_k,
//   T_jkl = Σ a_i n_ij [(c_i − p̃)_k (c_i − p̃)_l + (1/12) Σ_v (v − c_i)_k (v − c_i)_l]
// (the triangle's second moment about its centroid is a/12 Σ_v (v − c)(v − c)ᵀ). Nearer nodes
// are opened; leaves sum their triangles' solid angles exactly. β = 2 as in the paper. Measured
// against the exact sum (winding_bvh_test.cpp, docs/numerics.md): first order left errors of
// 6·10⁻² deep inside a sphere (hemisphere-sized nodes at 2r); second order brings the worst
// error to 3.1·10⁻³ on the icosphere, the open and the flipped cube and the Stanford bunny.
// Inside/outside (w ≥ ½) can differ from the exact sum only where the exact winding number is
// within that of ½, i.e. across a hole, never deep inside or outside a surface.
//
// Build: median splits on the longest axis of the centroids' box, leaves of at most 8 triangles
// whose moments are summed from their triangles, inner nodes' moments shifted up from their
// children's (O(n log n) for the splits, O(n) for the moments). Degenerate triangles contribute
// nothing and are left out.

#include <cstdint>
#include <memory>
#include <vector>

#include "engine/geometry/mesh.h"
#include "engine/math/ray.h"

namespace raycastd::engine {

class WindingBvh {
  public:
    /// The tree over `mesh`, which must outlive it.
    explicit WindingBvh(const TriangleMesh& mesh);

    /// The winding number at q (1 inside a closed outward-facing surface, 0 outside, fractional
    /// near holes); for q on a surface whatever the nearest triangles' solid angles give there.
    double winding_number(const Vec3d& q) const;

    /// Bytes held by the tree.
    std::size_t memory_bytes() const;

  private:
    struct Node {
        Vec3d centre;        ///< p̃: area-weighted centroid of the node's triangles
        double surface = 0;  ///< Σ a_i: the total area of the node's triangles
        double radius = 0;   ///< bounds |vertex − p̃| over the node's triangles (leaves: exact)
        Vec3d lo{kInfinity, kInfinity, kInfinity};  ///< the box of the node's vertices
        Vec3d hi{-kInfinity, -kInfinity, -kInfinity};
        Vec3d area;           ///< N = Σ a_i n_i
        double m[3][3] = {};  ///< M_jk = Σ a_i n_ij (c_i − p̃)_k
        double t[3][6] =
            {};  ///< T_jkl, (k, l) packed as xx yy zz xy yz zx (T is symmetric in k, l)
        std::uint32_t first = 0;  ///< leaf: first index into order_; inner: the left child
        std::uint32_t count = 0;  ///< leaf: number of triangles; 0 for an inner node
        std::uint32_t right = 0;  ///< inner: the right child (built after the left subtree)
    };
    /// A triangle and its centroid, while the tree is built.
    struct Item {
        Vec3d centroid;
        std::uint32_t triangle;
    };
    void build(std::uint32_t begin, std::uint32_t end, std::vector<Item>& items);
    /// A leaf's moments from its triangles.
    void summarise(Node& node, std::uint32_t begin, std::uint32_t end) const;
    /// An inner node's moments from its children's.
    static void merge(Node& node, const Node& l, const Node& r);
    double far_field(const Node& node, const Vec3d& q) const;

    const TriangleMesh& mesh_;
    std::vector<std::uint32_t> order_;  ///< triangle indices, leaves contiguous
    std::vector<Node> nodes_;           ///< nodes_[0] is the root
};

}  // namespace raycastd::engine
