#pragma once
// The accelerator's user geometry: primitives whose boxes Embree traverses in float but whose
// hits are decided by the engine's double kernels (engine/geometry). Spheres are user geometry
// in every BVH; in the exact BVH the triangles are too. Embree calls back into
//   bounds     the primitive's double box relative to the scene centre, padded by Impl::pad and
//              rounded outward to float, so that the float ray cannot cull a double hit;
//   intersect  the sphere roots or the watertight triangle test in double: in the exact BVH the
//              candidates compete by the API's `closer` order, in the native ones a sphere
//              competes with Embree's float triangle hits by float t;
//   occluded   any double hit in range.
// (The native BVH's triangles are decided in double by their hit filter: fat_triangles.h.)

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

}  // namespace raycastd::engine::embree
