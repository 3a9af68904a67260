#pragma once
// The accelerator's user geometry: primitives whose boxes Embree traverses in float but whose
// hits are decided by the engine's double kernels (engine/geometry). Spheres are user geometry
// in Embree's BVHs; exact's BVH (exact_bvh.h) takes every primitive's box and decision from
// here too (primitive_box, keep_candidates, occludes). Embree calls back into
//   bounds     the primitive's double box relative to the scene centre, padded by Impl::pad and
//              rounded outward to float, so that the float ray cannot cull a double hit;
//   intersect  the sphere roots in double: collected for all and count, or competing with
//              Embree's float triangle hits by float t (in exact's BVH every candidate competes
//              by the API's `closer` order: keep_candidates);
//   occluded   any double hit in range.
// (The native BVH's triangles are decided in double by their hit filter: fat_triangles.h.)

#include <cstdint>
#include <limits>

#include <embree3/rtcore.h>

#include "engine/accel/embree/device.h"
#include "engine/scene/scene.h"

namespace raycastd::engine::embree {

struct Impl;
struct RayContext;

/// A primitive's box as exact's BVH and Embree's user geometry take it: its double box relative
/// to the scene centre, padded by Impl::pad, in Embree's frame (Impl::frame), rounded outward to
/// float, so that the float ray cannot cull a double hit.
struct FloatBox {
    float lo[3], hi[3];
};
FloatBox primitive_box(const Impl& a, const Object& o, std::uint32_t prim);

/// The double hits of primitive `prim` of scene object `object` on c's ray (a sphere's roots in
/// range, a triangle's watertight hit; in c's frame, a far ray's spheres decided on the client's
/// ray: RayContext::far_spheres): with c.collect every one is collected; otherwise each is kept
/// as c.best if it comes first by the API's `closer` order, and `tfar` (the float ray's) is
/// lowered to its float t, rounded up with RayContext::margin (tfar_for), never below it.
void keep_candidates(RayContext& c, std::uint32_t object, std::uint32_t prim, float& tfar);

/// Whether primitive `prim` of `object` has a double hit on c's ray (an occlusion query).
bool occludes(const RayContext& c, std::uint32_t object, std::uint32_t prim);

/// What the callbacks of one geometry need: which object of which accelerator it is.
struct GeomData {
    const Impl* accel;
    std::uint32_t object;
    /// refined's hit filter defers a candidate on this object's widened triangles
    /// (RayContext::defer) only where (min(u, v, 1 − u − v)·|Ng|)² exceeds this (Embree's float
    /// barycentrics and geometric normal, in Impl::frame): the square of twice the widening
    /// times the longest widened edge (make_fat_triangle_geometry), so that the candidate lies,
    /// up to float rounding, at least twice the widening inside every edge (a barycentric weight
    /// times |Ng|/|e| is the distance from the edge e). Nearer an edge it may be a neighbour's
    /// widening, a double miss, whose deferral costs the lane a second traversal: 13,156 of
    /// workload B's 1M random rays (5.4% of those that hit) without this test, 7 with it. A cost
    /// filter only: the deferred decision is made in double all the same, and the answers do not
    /// depend on it. One band an object: an object with a few long triangles (a floor) defers
    /// little on its small ones.
    float defer_band2 = std::numeric_limits<float>::infinity();
};

/// A user geometry of `prims` primitives of data's object (1 for a sphere), with the callbacks
/// above; `data` must outlive it. Not yet committed.
GeometryHandle make_user_geometry(RTCDevice device, GeomData* data, unsigned prims);

}  // namespace raycastd::engine::embree
