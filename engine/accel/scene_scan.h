#pragma once
// A scene of a few primitives (QueryEngine's brute-force scenes: at most 16) traced by testing
// every primitive, for the millions of rays of a render. linear_accel.h answers the same
// questions for a handful of rays; this keeps the primitives in one flat array (a triangle's
// corners copied, not gathered through the mesh's index on every ray), decides t first and
// fills the answer's normal once for the winner, so that a render of the bench's six-primitive
// scene (four spheres and a floor) spends its time in the kernels rather than around them.
//
// At `exact` the answers are linear_closest's and linear_any's bit for bit: the same kernels
// (sphere_roots, intersect_triangle), the same tie rules (`closer` across objects, strictly
// closer within one), each mesh's triangles in file order; the spheres are tested before the
// meshes, which at exact does not change the answer (prims_). At `fast` a sphere is decided by
// the plain-double kernel (sphere_roots_fast), as fast's Embree path decides it, and a triangle
// by Woop's watertight test with t from its own shear (intersect_triangle_fast, no
// double-double plane crossing): still double, and within fast's error bounds.

#include <cstdint>
#include <optional>
#include <vector>

#include "engine/accel/far_ray.h"
#include "engine/geometry/sphere.h"
#include "engine/geometry/triangle.h"
#include "engine/scene/scene.h"

namespace raycastd::engine {

/// A triangle's plane as SceneScan's shortcut needs it: whether a ray certainly leaves the plane
/// behind (its origin strictly on one side, its direction strictly away, both beyond every
/// rounding of this test and of the kernels', tmin ≥ 0), in which case neither
/// intersect_triangle nor intersect_triangle_fast reports a hit.
struct TrianglePlane {
    Vec3d n;  ///< (b − a)×(c − a), rounded
    /// Per component, what s = n·(o − a) may be off by per unit of |o − a|: the rounded
    /// normal's error, the rounding of o − a and of the dot product, and plane_t's double-double
    /// resolution (see left_behind), summed once here rather than per ray.
    Vec3d s_err;
    Vec3d sd_err;         ///< the same for n·d per unit of |d|
    bool usable = false;  ///< no product of the normal underflows (else never left behind)

    static TrianglePlane of(const Triangle& tri);
    /// `a`: the first corner of the triangle this plane was made `of` (not kept here: the scan
    /// holds the triangle beside it).
    bool left_behind(const Ray& ray, const Vec3d& a) const;
    /// Whether the ray certainly misses for this plane alone: left_behind, or the line crosses
    /// ahead but beyond tmax by more than plane_t's rounding of that crossing (the scan's test;
    /// intersect_triangle and decide_triangle report no hit for it either, and
    /// intersect_triangle_fast only where its sheared t, within t_err of the crossing, falls
    /// inside tmax: a grazing ray, whose miss here is the crossing's true side).
    bool missed(const Ray& ray, const Vec3d& a) const;
};

namespace detail {
/// Four spheres side by side, for SceneScan::sphere_candidates(): lane k of entry j is sphere
/// 4j + k (lanes past the last sphere hold a centre at 0 and r² = 0; whatever the rule makes of
/// them is never reported, since SceneScan::cullable_ has no bit for them).
struct alignas(32) SphereQuad {
    double cx[4], cy[4], cz[4];  ///< centres
    double r2[4];                ///< radius², rounded
};
/// SceneScan's rule over n quads of spheres, in one instruction set's lanes (scene_scan.cpp).
using RuledOut = std::uint32_t (*)(const SphereQuad* quads, std::size_t n, const Ray& ray);
}  // namespace detail

class SceneScan {
  public:
    /// A scan of `scene` (its primitives copied: the scan does not refer to it); `fast`: the
    /// fast kernels.
    SceneScan(const Scene& scene, bool fast);

    /// The closest hit in [tmin, tmax], or nullopt (linear_closest at exact).
    std::optional<Hit> closest(const Ray& ray, bool want_normal) const;
    /// The same written into `out` (all of it but its normal where `want_normal` is false);
    /// false, and `out` untouched, on a miss. A batch's own slot: a Hit returned and copied
    /// in was read back in 16-byte pieces of what had been written in 4- and 8-byte ones, a
    /// store-forwarding stall per camera ray (perf annotate of Tracer::closest_batch).
    bool closest(const Ray& ray, bool want_normal, Hit& out) const;
    /// Whether anything is hit in [tmin, tmax] (linear_any at exact).
    bool any(const Ray& ray) const;
    /// Whether `ray` comes from so far away (SceneBall::far) that the brute-force paths move it
    /// to the scene (linear_closest_from_afar and the others, far_ray.h), which the scan does
    /// not: its caller answers such a ray there. Decided on the far ray itself the kernels err
    /// by ~u·distance: from 1e20 a camera's ray at `fast` hit a sphere behind the triangle it
    /// crosses (a helper's review).
    bool far(const Ray& ray) const { return ball_.far(ray); }
    /// Bit k set: the k-th sphere (in object order) may be hit; clear: the ray's line certainly
    /// misses it, or it lies behind the origin and tmin ≥ 0, so that neither sphere_roots nor
    /// sphere_roots_fast finds a root in range. Public for tests.
    std::uint32_t sphere_candidates(const Ray& ray) const {
        // No sphere that may be ruled out (none at all, or none whose r² the bounds hold for):
        // every bit set, as the rule would leave it, without the call.
        if (cullable_ == 0)
            return ~std::uint32_t{0};
        return ~(ruled_out_(spheres_.data(), quads_, ray) & cullable_);
    }
    /// How many spheres sphere_candidates() tests at a time: two in SSE2's registers, or four in
    /// AVX's where the processor has it (the same operations in each lane, so the same bits).
    enum class Lanes { two, four };
    /// The lanes this processor runs: four where it has AVX.
    static Lanes widest_lanes();
    /// sphere_candidates() in the given lanes (four taken as two where widest_lanes() says the
    /// processor has no AVX); for tests.
    std::uint32_t sphere_candidates(const Ray& ray, Lanes lanes) const;
    /// Whether sphere k is among the candidates (beyond the 32 bits: always).
    static bool may_hit(std::uint32_t candidates, std::uint32_t k) {
        return k >= 32 || ((candidates >> k) & 1u) != 0;
    }

  private:
    /// A mesh's triangle.
    struct Primitive {
        Triangle tri;          ///< its corners
        Vec3d normal;          ///< triangle_normal(tri), made once
        TrianglePlane plane;   ///< its plane
        std::uint32_t object;  ///< the scene's object index
        std::uint32_t index;   ///< the triangle's index in its mesh
        bool last_of_object;   ///< the object's last triangle (its own best is then settled)
    };
    /// A sphere; the k-th in object order is bit k of sphere_candidates().
    struct ScanSphere {
        Sphere sphere;
        std::uint32_t object;  ///< the scene's object index
    };
    using SphereQuad = detail::SphereQuad;

    SphereRoots roots(const Sphere& s, const Ray& ray) const;
    std::optional<Hit> triangle(const Triangle& tri, const Ray& ray) const;
    /// Whether triangle() would hit, for `any`: at refined and exact decide_triangle, which
    /// decides as intersect_triangle without its plane crossing where Woop's t settles the range.
    bool hits_triangle(const Triangle& tri, const Ray& ray) const;
    /// Calls `f(sphere)` on each sphere the ray may hit, in object order (the candidates among
    /// the first 32, by their bits in sphere_candidates(), then every sphere past them), until
    /// f returns true; returns whether it did. closest() and any() walk the spheres this way.
    template <class F>
    bool find_sphere(const Ray& ray, F&& f) const;

    SceneBall ball_;  ///< for far()
    /// The meshes' triangles, object by object, each mesh's in file order. The spheres are
    /// tested first, each candidate only (sphere_candidates), and then the triangles, where a
    /// loop over every primitive in object order had spent a test and a branch on each sphere
    /// of every ray (in bench_render's tutorial_like, four spheres, of which most rays are
    /// candidates for none). At exact the answer does not depend on the order: `closer`
    /// decides between objects, and every bound is inclusive. At fast it can, within fast's
    /// bounds, between a mesh listed before a sphere and that sphere where their crossings lie
    /// within the fast kernels' error of each other: the mesh now gets the sphere's t as its
    /// bound, and TrianglePlane::missed culls it by its exact crossing where the fast kernel's t
    /// may come earlier (SceneScan.FastNearTiesOfAMeshListedBeforeASphereStayWithinTheBounds).
    /// The spheres listed first, as in the bench's scenes, nothing changes.
    std::vector<Primitive> prims_;
    std::vector<ScanSphere> sphere_list_;  ///< the spheres, in object order
    /// Bit k set for each of the first 32 spheres (the bits sphere_candidates() holds).
    std::uint32_t sphere_bits_ = 0;
    std::vector<SphereQuad> spheres_;
    /// Bit k set: sphere k may be ruled out by sphere_candidates (its r² lies in
    /// [2⁻¹⁰⁰⁰, 2¹⁰⁰⁰], where the bounds' relative terms hold).
    std::uint32_t cullable_ = 0;
    /// The rule over the first `quads_` quads in the widest lanes this processor runs
    /// (widest_lanes()), chosen once: a render asks sphere_candidates() of every ray, and its
    /// choice on every call (the processor's features, the lanes, the quads' count) had cost
    /// 2.09M instructions of bench_render --smoke's render, 0.64M now (cachegrind).
    detail::RuledOut ruled_out_ = nullptr;
    std::size_t quads_ = 0;  ///< min(spheres_.size(), 8): 32 bits of candidates
    bool fast_;
};

}  // namespace raycastd::engine
