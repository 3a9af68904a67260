#pragma once
// The quad-precision reference for the point queries (issue 18): the distance from a point to a
// triangle mesh, and the winding number that says inside or outside. Used only by tests and by
// the accuracy report (points_accuracy, bench/accuracy_points.py).
//
// Distance: not the engine's method (Ericson's Voronoi regions in double,
// geometry/closest_point.h) but "project, then the edges": the plane's foot of p is inside the
// triangle when the three triple products n·((v_{i+1} − v_i) × (p − v_i)) share the sign of
// n·n, and the distance is then |n·(p − a)|/|n|; otherwise it is the least of the three segment
// distances |p − s₀ − t·e| with t = clamp((p − s₀)·e/e·e, 0, 1). In __float128 (u_q = 2⁻¹¹³)
// every difference of the double inputs is exact and every product of two of them too, so the
// reference's own error is a few u_q of the distance scale, ~20 orders below a double ulp.
// Only triangles the double kernel puts within 10⁻⁹ (relative) of its own nearest are evaluated
// (the double kernel's error is ~16 u: far inside that).
//
// Winding number: the sum of the triangles' solid angles (Van Oosterom & Strackee 1983,
// geometry/solid_angle.h) over 4π, every triangle, in double: on a closed mesh it is an integer
// to ~1e-12 away from the surface, which is all the sign judgement needs (points within 10⁻⁹ of
// the scale of the surface are on it and not judged).

#include <vector>

#include "engine/geometry/mesh.h"
#include "tests/stress/reference.h"

namespace raycastd::stress {

/// The distance from p to one triangle, in quad precision.
Quad reference_triangle_distance(const engine::Triangle& tri, const engine::Vec3d& p);

/// The distance from p to the mesh (its non-degenerate triangles), in quad precision.
Quad reference_distance(const engine::TriangleMesh& mesh, const engine::Vec3d& p);

/// The generalized winding number of the mesh at p (exact sum of solid angles, in double).
double reference_winding(const engine::TriangleMesh& mesh, const engine::Vec3d& p);

}  // namespace raycastd::stress
