#pragma once
// The accelerator's user geometry: primitives whose boxes Embree traverses in float but whose
// hits are decided by the engine's double kernels (engine/geometry). Spheres are user geometry
// in every BVH; in the exact BVH the triangles are too. Embree calls back into
//   bounds     the primitive's double box relative to the scene centre, padded by Impl::pad and
//              rounded outward to float, so that the float ray cannot cull a double hit;
//   intersect  the sphere roots or the watertight triangle test in double: in the exact BVH the
//              candidates compete by the API's `closer` order, in the native ones a sphere
//              competes with Embree's float triangle hits by float t;
//   occluded   any double hit in range;
// and `collect_filter` records every float triangle hit of an `all` query on the native BVH.

#include <cstdint>

#include <embree3/rtcore.h>

#include "engine/accel/embree/device.h"

namespace raycastd::engine::embree {

struct Impl;

/// What the callbacks of one geometry need: which object of which accelerator it is.
struct GeomData {
    const Impl* accel;
    std::uint32_t object;
};

/// A user geometry of `prims` primitives of data's object (1 for a sphere), with the callbacks
/// above; `data` must outlive it. Not yet committed.
GeometryHandle make_user_geometry(RTCDevice device, GeomData* data, unsigned prims);

/// Context filter for `all` on the native BVH: records each float triangle hit in the
/// RayContext's `collect` list (t, u, v as Embree found them), then rejects it so that the
/// traversal goes on to the next one. Spheres report through their own callback.
void collect_filter(const RTCFilterFunctionNArguments* args);

}  // namespace raycastd::engine::embree
