#pragma once
// PointBvh: closest points over a scene's triangles without Embree's point query, for speed.
//
// Why: rtcPointQuery calls back for every triangle of each leaf whose box meets the query sphere
// (200–1,000 per point on an 82k-triangle icosphere: the distance function is flat near its
// minimum, so a whole cap of leaves is within a box's size of the nearest distance), and each
// callback decided its triangle exactly in double. Here a BVH of our own (built binary, median
// splits, then collapsed to four children a node, whose four boxes one SIMD step tests) is
// walked nearest child first (children ordered by the distance to their float boxes), and each
// leaf's triangles first get a conservative lower bound of their distance in float, four at a
// time; only a triangle whose bound does not exceed the best distance so far (plus the ties'
// margin, PointCandidates::cull_distance) is decided exactly in double by the kernel of
// geometry/closest_point.h. The answer is the one brute force gives (same winner, same bits):
// PointCandidates decides, the tree only culls (the order it visits triangles in does not
// change the winner: geometry/closest_point.h).
//
// The lower bound (one triangle T with unit normal n and in-plane outward edge normals m_e, all
// rounded to float): T lies in the slab |n·x − o| ≤ r and in each half-space m_e·x ≤ o_e, so for
// any x in T and w = p − x, |n·w| ≥ A = |n·p − o| − r and m_e·w ≥ B_e = m_e·p − o_e. Projecting
// w on span(n, m_e), whose Gram matrix is [[1, c], [c, 1]] with c = n·m_e:
//   |w|² ≥ (a² − 2c·ab + b²)/(1 − c²) ≥ (a² + b²)/(1 + |c|)   (a = n·w, b = m_e·w),
// hence d(p, T)² ≥ (A₊² + max_e B_e₊²)/(1 + |c|), the distance to the plane and to the farthest
// edge line combined by Pythagoras (exact in the face and edge regions: Ericson, RTCD §5.1.5).
// The plane alone would not do: seen from outside a convex surface the planes of the triangles
// around the nearest one come closer, not farther. Past an acute corner v (p beyond both of its
// edges' lines) that in-plane term is too weak (half the distance to v at 60°); there the nearest
// point of T is v itself (the corner's Voronoi region, RTCD §5.1.5: for an angle ≤ 90° the
// region beyond both lines is the corner's), so the bound is |p − v| — tested only where both
// B's exceed ε, which puts the true p beyond both true lines whatever the float rounding did.
// Float enters in named steps (point_bvh.cpp):
// the planes are fitted in double and their offsets moved out over every vertex (so T is inside
// them exactly), |c| and | |n| − 1 | are checked ≤ 2⁻²⁰ at build, and the query's float
// evaluation and the rounding of p are covered by an absolute margin ε = 40·u_f·(|q|∞ + S)
// (S: twice the largest coordinate relative to the centre), the remaining relative roundings by
// the factor 1 + 2⁻¹⁶ on the squared radius. A triangle whose planes fail those checks (a
// near-degenerate sliver) gets a bound of 0: it is always decided exactly. Beyond 64 S from the
// centre the walk is in double (point_bvh.cpp, docs/numerics.md: the same planes, the Gram bound
// kept whole, balls around the nodes), since ε and the float frames' rounding grow with |q|.
//
// Memory: 64 B a triangle for the four planes, 36 B for the float corners, 8 B for its object and
// primitive, and the 4-wide nodes (272 B, one per ~20 triangles): 123–126 B a triangle
// (bench_points), built on a scene's first point query (QueryEngine::closest_point). Spheres are
// not in the tree: a scene with at most kMaxSpheres of them has each one decided first (which also
// starts the search with a small radius); with more, QueryEngine stays on Embree's point query.

#include <cstdint>
#include <optional>
#include <vector>

#include "engine/geometry/closest_point.h"
#include "engine/scene/scene.h"

namespace raycastd::engine {

/// The four planes of one triangle as stored (relative to the scene's centre); all zero (every
/// bound 0) for a triangle that fails the checks of the file comment.
struct TrianglePlanes {
    float plane[4] = {};     ///< n (unit, float) and o: T lies within `slab` of n·x = o
    float edges[3][4] = {};  ///< m_e and o_e: T lies in m_e·x ≤ o_e (in-plane outward normals)
    /// Corner i (between edges i−1 and i) rounded to float where it is acute and the triangle
    /// well-shaped (the corner rule of the file comment); NaN where it is not.
    float corner[3][3] = {};
};

/// Four triangles' planes, lane by lane (component-major, so that the bound vectorises).
struct alignas(16) PlanePack {
    float plane[4][4] = {};      ///< [n.x, n.y, n.z, o][lane]
    float edges[3][4][4] = {};   ///< [edge][m.x, m.y, m.z, o][lane]
    float corner[3][3][4] = {};  ///< [corner][x, y, z][lane]
};

/// Lane `lane` of `pack` set to t.
void set_lane(PlanePack& pack, int lane, const TrianglePlanes& t);

/// The margins of one query's bounds: `plane` for the planes' (and the boxes') evaluation and
/// p's rounding, `region` for the corner rule's test that p is beyond both of a corner's edges,
/// `corner` for the distance to the corner.
struct BoundMargins {
    double plane = 0, region = 0, corner = 0;
};

/// The margins for a query point at |q|∞ from the centre of a tree whose S is `scale`: in float
/// (all three the ε of the file comment), or in double for a far point.
BoundMargins float_margins(double qmax, double scale);
BoundMargins double_margins(double qmax, double scale);

/// The squared lower bounds of the four lanes' triangles' distances from q (relative to the
/// centre), each up to the factor 1 + 2⁻¹⁶ with float_margins' ε; 0 for zero planes.
void lower_bounds2(const PlanePack& pack, const float q[3], float eps, float out[4]);
/// The same in double, for a far q (double_margins; from about 10⁴ scene sizes away float's
/// rounding of q would reach the triangles' size and nothing would be culled).
void lower_bounds2(const PlanePack& pack, const double q[3], const BoundMargins& m, double out[4]);

/// The planes of the triangle (a, b, c), given relative to the centre; `slab` is the largest
/// r = max |n·v − o| a triangle may have (beyond it, or when the checks of the file comment fail,
/// the planes are invalid and all zero).
TrianglePlanes triangle_planes(const Vec3d& a, const Vec3d& b, const Vec3d& c, double slab);

class PointBvh {
  public:
    /// At most this many spheres are decided one by one before the tree is walked.
    static constexpr std::size_t kMaxSpheres = 16;

    /// Whether the tree can answer for `scene`: some triangle, at most kMaxSpheres spheres, and
    /// a diagonal of at most 1e16 (the float walk squares distances of up to 64 S).
    static bool suits(const Scene& scene);

    /// The tree over every non-degenerate triangle of `scene`, which must outlive it.
    explicit PointBvh(const Scene& scene);

    /// The closest surface point to p within max_distance (inclusive), the same answer as
    /// linear_closest_point (accel/point_query.h); nullopt when nothing is that close or p is not
    /// finite.
    std::optional<PointHit> closest_point(const Vec3d& p, double max_distance) const;

    /// Bytes held by the tree.
    std::size_t memory_bytes() const;

  private:
    /// An oriented box around the node's triangles: {x : |axes_k·(x − centre)| ≤ half_k}.
    struct Node {
        float axes[3][3];  ///< rows, unit and orthogonal within 2⁻²⁰ (the world axes: a plain box)
        float centre[3];
        float half[3];            ///< half-extents along the axes, rounded up
        std::uint32_t index = 0;  ///< leaf: first pack; inner: the right child (left is next)
        std::uint32_t count = 0;  ///< leaf: triangles (≥ 1); 0 for an inner node
    };
    /// Four children of the walked tree, lane by lane: the binary tree collapsed two levels at a
    /// time (a node and its grandchildren), so the walk tests four boxes in one SIMD step.
    struct alignas(16) Node4 {
        float axes[3][3][4];  ///< [row][component][lane]: each lane's box frame
        float centre[3][4];
        float half[3][4];
        std::uint32_t child[4];  ///< inner: a Node4; leaf: its first pack; kInvalidId: no child
        std::uint32_t count[4];  ///< leaf: its triangles; 0 for an inner child
    };
    /// Four triangles of a leaf (a leaf's last pack may have fewer).
    struct Pack {
        PlanePack planes;
        std::uint32_t object[4], prim[4];  ///< padding lanes: kInvalidId
    };
    /// The squared search radii of one query, kept in step with its candidates.
    template <class T>
    struct Reach;
    /// A triangle while the tree is built.
    struct Item {
        Vec3d centroid;
        Bounds3 box;   ///< relative to the centre
        Vec3d normal;  ///< (b − a) × (c − a)
        std::uint32_t object, prim;
    };
    /// The subtree over items[begin, end) at nodes_[index] (pre-order), its leaves' packs from
    /// packs_[pack] on.
    void build(std::uint32_t begin, std::uint32_t end, std::vector<Item>& items,
               std::uint32_t index, std::uint32_t pack);
    /// The node's box around `points` (relative to the centre, as computed), oriented along
    /// normal_sum where `oriented` and the points are nearly flat.
    static void fit(Node& node, const std::vector<Vec3d>& points, bool oriented,
                    const Vec3d& normal_sum, double area_sum);
    void fill_leaf(std::uint32_t node, std::uint32_t pack, std::uint32_t begin, std::uint32_t end,
                   const std::vector<Item>& items);
    /// The triangle of (object, prim) relative to the centre.
    Triangle relative(std::uint32_t object, std::uint32_t prim) const;
    /// The walk from the root with q (p relative to the centre) in float or, far away, double.
    template <class T>
    void walk(const Vec3d& p, const T q[3], Reach<T>& reach, PointCandidates& c) const;
    /// The lower bounds of a leaf's triangles, and the exact test of those still within reach.
    template <class T>
    void visit_leaf(std::uint32_t first_pack, std::uint32_t count, const Vec3d& p, const T q[3],
                    Reach<T>& reach, PointCandidates& c) const;
    /// The Node4 over binary node `b` (inner) and those below it; returns its index.
    std::uint32_t collapse(std::uint32_t b);

    const Scene& scene_;
    Bounds3 bounds_;           ///< the scene's, for PointCandidates' error bound
    Vec3d center_;             ///< bounds_'s centre
    double scale_ = 0;         ///< S of the file comment
    std::vector<Node> nodes_;  ///< the binary tree, while it is built
    std::vector<Node4> nodes4_;
    std::vector<Pack> packs_;
    std::vector<std::uint32_t> spheres_;
};

}  // namespace raycastd::engine
