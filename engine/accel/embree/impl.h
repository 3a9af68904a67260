#pragma once
// EmbreeAccel's internals, shared by embree_accel.cpp and the files of engine/accel/embree/:
// Impl (the BVHs, and the float frame Embree computes in), RayContext (the per-ray data that
// travels through Embree to our callbacks), NativeHit (what a float traversal reported).
// Nothing here leaves engine/accel: the public header forward-declares Impl only.

#include <atomic>
#include <cstdint>
#include <limits>
#include <mutex>
#include <optional>
#include <vector>

#include <embree3/rtcore.h>

#include "engine/accel/embree/build_buffer.h"
#include "engine/accel/embree/device.h"
#include "engine/accel/embree/exact_bvh.h"
#include "engine/accel/embree/user_geometry.h"
#include "engine/accel/far_ray.h"
#include "engine/scene/scene.h"

namespace raycastd::engine::embree {

/// The BVHs over one scene and the frame they share.
struct Impl {
    const Scene* scene = nullptr;
    /// The vertices and indices of native's triangles, released once it is built (and so
    /// before any query), freed after it (declared before it: build_buffer.h).
    BuildBuffer native_buffer;
    /// Fat float triangles (fat_triangles.h) + sphere user geometry, ROBUST: refined, fast's
    /// all, and the point queries' culling.
    SceneHandle native;
    /// fast's vertices and indices, as native_buffer holds native's (declared before `fast`).
    mutable BuildBuffer fast_buffer;
    /// The float triangles as they are, and the same spheres, in a BVH without
    /// RTC_SCENE_FLAG_ROBUST, for fast's closest and any (see build_fast); built by the first
    /// such query.
    mutable SceneHandle fast;
    mutable std::atomic<bool> fast_ready{false};
    mutable std::once_flag fast_once;
    mutable Status fast_status;
    mutable ExactBvh exact;  ///< every primitive's padded box, double tests (exact_bvh.h)
    mutable std::atomic<bool> exact_ready{false};
    mutable std::once_flag exact_once;
    mutable Status exact_status;
    std::vector<GeomData> geoms;  ///< one per object, stable addresses (reserved up front)
    Bounds3 padded_bounds;
    /// padded_bounds relative to `center`, rounded outward: the bounds a ray given relative to
    /// the centre (a far ray moved to the scene: move_near_scene) is clipped against.
    Bounds3 padded_bounds_rel;
    /// Embree sees every coordinate relative to this point (the centre of the scene bounds):
    /// float precision then follows the scene's size, not its distance from the origin.
    Vec3d center;
    /// ... and times this power of two, which brings the scene's size to [1, 2) (frame()):
    /// Embree's float tests multiply up to three coordinates and use absolute constants (its
    /// rays must lie within 1.8e18, and it flushes subnormals to zero), so they are right only
    /// for scenes of moderate size. Unscaled, a mesh 1e-14 across was missed at fast, one 1e-20
    /// across at refined too, one 1e14 across answered t = inf at fast, one 1e18 across aborted the
    /// process on an assertion in Embree, and from 1e20 every precision missed. Float t is in units
    /// of the frame too: RayContext::len includes `unit`.
    double unit = 1.0;
    /// p in Embree's frame: (p − center)·unit (exact scaling: unit is a power of two).
    Vec3d frame(const Vec3d& p) const { return (p - center) * unit; }
    double pad = 0;          ///< absolute padding of every box, in scene units (see build)
    double float_scale = 0;  ///< magnitude of scene coordinates, for the fast path's t_err
    std::size_t triangles = 0, spheres = 0;
    /// Whether a float miss on `native` is a miss (fat_triangles.h): every triangle could be
    /// widened fully. False: refined confirms its float misses on the exact path.
    bool certified_misses = true;
    /// The objects that are triangles or meshes, in order (refined's scan of few triangles).
    std::vector<std::uint32_t> triangle_objects;

    /// The frame, the padding and the padded bounds for a scene whose bounds are `b` (nothing
    /// for empty bounds): what EmbreeAccel::build sets up before any BVH.
    void set_frame(const Bounds3& b);
    void build_exact() const;
    void build_fast() const;
    // fast_scene() and exact_bvh() build on first use, often inside a task of a parallel batch
    // or render, under call_once without tbb::this_task_arena::isolate (which PerObjectOnce
    // needs, query/per_object_once.h): a thread waiting in a build's own parallel loop could
    // otherwise take another task of the batch, which would call again on the flag it holds.
    // Neither build can: exact's is serial, and Embree 3.13 runs rtcCommitScene's build in a
    // tbb::isolated_task_group where TBB is 2019 Update 9 or later (Debian 12 has oneTBB
    // 2021.8; Embree's TASKING_TBB_USE_TASK_ISOLATION: Debian's libembree3 imports TBB's
    // isolate_within_arena, nm -D). A build made parallel here must isolate.
    /// The scene fast's closest and any trace: the non-robust one, or `native` if it could not
    /// be built.
    RTCScene fast_scene() const {
        std::call_once(fast_once, [this] { build_fast(); });
        return fast_status.ok() ? fast.get() : native.get();
    }
    /// The exact BVH, or nullptr if it could not be built (the caller then scans linearly).
    const ExactBvh* exact_bvh() const {
        std::call_once(exact_once, [this] { build_exact(); });
        return exact_status.ok() ? &exact : nullptr;
    }
};

/// A far ray moved to the scene (RayContext::frame), whose spheres the exact BVH's callbacks
/// decide on the client's ray instead, as the brute-force paths do (linear_accel.cpp): the
/// sphere kernel forms o − c exactly and f × d to a few u² of itself (cross_far, sphere.cpp)
/// and loses nothing to the distance, while the moved origin, rounded by u of its distance from
/// the centre, lies up to MovedRay::line_err off the line, which decided near-tangent lines
/// wrongly (a probe: 42–67 of 2,000 lines 1e-9 of a radius from a sphere 2e-6 across, in a
/// scene 10 across, from 2^43 to 2^73 away; 0 on the client's ray). The traversal still culls by
/// the moved ray (it lies within line_err, far below the boxes' padding, of the client's line), and
/// a sphere's hit competes there at its t on the moved ray (user_geometry.cpp).
struct FarSpheres {
    /// Keeps pointers to both rays, which must outlive it (temporaries are refused).
    FarSpheres(const Ray& client_ray, const MovedRay& moved_ray)
        : client(&client_ray), moved(&moved_ray) {}
    FarSpheres(Ray&&, const MovedRay&) = delete;
    FarSpheres(const Ray&, MovedRay&&) = delete;
    const Ray* client;
    const MovedRay* moved;
    /// closest: RayContext::best as decided on `client`, when it is a sphere's.
    std::optional<Hit> best;
    /// all: every sphere hit, decided on `client`, and the same at its place on the moved ray
    /// (sphere_on_moved), for the order of the list.
    std::vector<Hit> hits, hits_moved;
};

/// The context handed through Embree to our callbacks (Embree's documented way to pass per-ray
/// data: a struct that starts with RTCIntersectContext).
struct RayContext {
    RTCIntersectContext rtc;
    const Impl* accel = nullptr;
    const Ray* ray = nullptr;  ///< the double-precision ray
    double shift = 0;          ///< the float ray starts at ray.at(shift)
    double len = 1;     ///< |direction|·Impl::unit: float t' (frame units) ↔ t = shift + t'/len
    double margin = 0;  ///< slack added to tfar, in frame units (Impl::unit)
    double origin_err = 0;  ///< bound on the double rounding of the float ray's start point
    /// The origin is so far from the scene (~1e8 scene sizes and beyond) that prepare_ray formed
    /// the start point in double-double, or could not place it: the double kernels, deciding on
    /// the ray itself, err there by ~u·distance (a whole scene size from 1e16 on). refined and
    /// exact answer such a ray moved along its line to the scene (move_near_scene).
    bool far = false;
    /// When set, `ray` is given relative to this point (the scene centre), and the callbacks
    /// translate each primitive by it before the double tests (a moved far ray: its origin
    /// relative to the centre is accurate to a few u² of the distance, where in world
    /// coordinates it would round by u·|centre|).
    const Vec3d* frame = nullptr;
    /// A primitive in the frame the double tests decide in (translated by `frame` if set).
    Sphere in_frame(Sphere s) const {
        if (frame)
            s.center = s.center - *frame;
        return s;
    }
    Triangle in_frame(const Triangle& t) const {
        return frame ? Triangle{t.a - *frame, t.b - *frame, t.c - *frame} : t;
    }
    /// Set with `frame` on the exact BVH: the spheres are decided on the client's ray.
    FarSpheres* far_spheres = nullptr;
    /// Closest so far: the exact path's, or on `native` the first by `closer` of the double
    /// hits Embree offered within its float tfar (a sphere's, or a fat triangle's from the hit
    /// filter; keep_if_closer in float_ray.h).
    std::optional<Hit> best;
    std::vector<Hit>* collect = nullptr;  ///< all/count: every hit goes here
    /// A closest query that wants the normal: refined's hit filter and the exact BVH's callback
    /// give each double hit on a triangle its unit normal (intersect_triangle's, from the edge
    /// cross product its degeneracy test formed), so that the answer need not read the triangle
    /// again for it (9% of a refined batch of camera rays, perf); where it is not set, the
    /// answer forms the normal itself. Not set for a far ray moved into the centre's frame
    /// (`frame`), whose translated triangles' normals are not the triangles' own.
    bool want_normal = false;
    bool fast = false;  ///< precision fast: spheres by the plain-double kernel
    /// Float t (Embree's units) of `best` on the native BVH.
    float best_tf = std::numeric_limits<float>::infinity();
    /// The smallest float t at which the hit filter rejected a candidate (the ray passed within
    /// the widening of an edge of a triangle it does not hit in double); +inf if none. A miss,
    /// or a hit beyond it, is then confirmed on the exact path. Not counted: a crossing well
    /// inside its triangle rejected for its t alone (outside_range_well_inside).
    float rejected_tf = std::numeric_limits<float>::infinity();
    bool rejected() const { return rejected_tf < std::numeric_limits<float>::infinity(); }
    /// A packet's context: the lanes' own contexts, indexed by the Embree ray id.
    RayContext* lanes = nullptr;
    /// On a packet's context: refined's hit filter may defer a lane's decisions (fat_triangles.h,
    /// settle_pending_lanes). A candidate offered to a lane alone (a call of the filter with one
    /// lane on), while the lane has no hit, nothing pending and no retrace, is then accepted
    /// undecided (its triangle's index row prefetched) and decided after the traversal with the
    /// packet's other deferred lanes, where their cache misses overlap.
    bool defer = false;
    /// The deferred candidate (its object's GeomData, primitive and float t), if any.
    const GeomData* pending_geom = nullptr;
    unsigned pending_prim = 0;
    float pending_tf = 0;
    /// The deferred decision would have changed the traversal (a double miss, or a hit within
    /// 1e-6 of an edge in barycentrics, whose tfar keep_if_closer raises): the lane's answer is
    /// traced again as a ray alone, every candidate decided when offered, and nothing of this
    /// traversal is used for it.
    bool retrace = false;

    /// A packet lane's context (never handed to Embree: packets carry no user geometry).
    RayContext() = default;
    /// A context for one ray through `a`'s BVHs.
    explicit RayContext(const Impl& a) : accel(&a) { rtcInitIntersectContext(&rtc); }
};

/// The RayContext behind the context pointer Embree hands to a callback.
inline RayContext& ctx_of(RTCIntersectContext* c) {
    return *reinterpret_cast<RayContext*>(c);
}

/// What Embree's native traversal reported for one ray (geom is RTC_INVALID_GEOMETRY_ID on a
/// miss); tfar is in the float ray's units (RayContext::shift and len map it back).
struct NativeHit {
    unsigned geom, prim;
    float tfar, u, v;
    Vec3d ng;
};

/// Whether rtcOccluded found something: it sets tfar to −∞ on a hit.
inline bool occluded_tfar(float tfar) {
    return tfar == -std::numeric_limits<float>::infinity();
}

}  // namespace raycastd::engine::embree
