#pragma once
// Closest-point queries over a scene's primitives: the candidate step both accelerators share
// (one primitive's exact closest point in double, offered to the running PointCandidates), and
// brute force over every primitive for the scenes QueryEngine answers without a BVH. The BVH
// path is EmbreeAccel::closest_point (engine/accel/embree/point_query.cpp), which culls with
// Embree's point query and decides with the same step.

#include <cstdint>
#include <optional>

#include "engine/geometry/closest_point.h"
#include "engine/scene/scene.h"

namespace raycastd::engine {

/// Offers primitive `prim` of object `object` (a sphere's only primitive is 0) to `c` when its
/// closest point to p is within max_distance; degenerate triangles are never offered. The hit's
/// normal is left for finish_closest_point.
void offer_primitive(const Scene& scene, std::uint32_t object, std::uint32_t prim, const Vec3d& p,
                     double max_distance, PointCandidates& c);

/// Offers cp, the closest point of primitive `prim` of `object`, to `c` when it is within
/// max_distance (the step offer_primitive ends with; PointBvh computes cp itself).
void offer_closest_point(const ClosestPoint& cp, std::uint32_t object, std::uint32_t prim,
                         double max_distance, PointCandidates& c);

/// The winner of `c` with its unit geometric normal filled in; nullopt when there is none.
std::optional<PointHit> finish_closest_point(const Scene& scene, const PointCandidates& c);

/// The closest surface point to p within max_distance (inclusive) over every primitive of the
/// scene, ties by the API's rule (geometry/closest_point.h); nullopt when nothing is that close.
std::optional<PointHit> linear_closest_point(const Scene& scene, const Vec3d& p,
                                             double max_distance);

}  // namespace raycastd::engine
