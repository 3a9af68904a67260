#pragma once
// intersect_triangle on up to four rays against one triangle at a time, in AVX2's registers.
//
// Why. refined's hit filter (engine/accel/embree/fat_triangles.cpp) decides every float
// candidate Embree reports in double, and Embree's packet kernels report one triangle to it
// together with every lane of the packet that hit it: on the camera rays of the bench's
// icosphere (workload A) about four lanes a call. One at a time, Woop's test and the plane
// crossing were about 1,000 instructions a candidate, over half of a refined batch (callgrind,
// 2026-12-06). Here the lanes share the triangle's own quantities (its edge cross product and
// normal, the plane crossing's scaled edges), formed once, and the per-ray arithmetic runs in
// four lanes.
//
// Bit for bit. Each lane performs intersect_triangle's operations in its order (no contraction:
// the project builds with -ffp-contract=off; a fused multiply-add only where dd::two_prod and
// dd::mul use std::fma), so a lane it decides gets the same Hit, or the same miss and the same
// LineCrossing, as intersect_triangle. It decides only the common path: a triangle and ray of
// ordinary scale (woop's rescaling not needed), every edge function beyond its rounding bound
// (no exact triple product), Woop's t and its bound finite, and the plane crossing settled by
// its plain-double normal. Every other lane is left to intersect_triangle.

#include <optional>

#include "engine/geometry/triangle.h"

namespace raycastd::engine {

/// Whether intersect_triangle_lanes decides lanes on this processor (AVX2 and FMA); where it
/// does not, every lane is left undecided.
bool triangle_lanes_available();

/// intersect_triangle(tri, *rays[k], want_normal, &outside[k]) for each k < count (count ≤ 4):
/// returns the lanes it left undecided (bit k), which the caller decides with
/// intersect_triangle. Each other lane's hits[k] is what intersect_triangle returns, and where
/// that would write the LineCrossing, outside[k] is written with it (else left as it is).
unsigned intersect_triangle_lanes(const Triangle& tri, const Ray* const rays[], unsigned count,
                                  bool want_normal, std::optional<Hit> hits[],
                                  LineCrossing outside[]);

/// The same for decide_triangle(tri, *rays[k], &outside[k]) (an occlusion test's decision: the
/// sheared t where it settles the range).
unsigned decide_triangle_lanes(const Triangle& tri, const Ray* const rays[], unsigned count,
                               std::optional<Hit> hits[], LineCrossing outside[]);

}  // namespace raycastd::engine
