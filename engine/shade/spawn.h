#pragma once
// Robust origins for secondary rays (pbrt-v4 §6.8.6, "Robust Spawned Ray Origins").
//
// A hit point p = o + t·d is only known to within an error box: |d|·t_err from the
// intersection's t, plus the rounding of the product and the sum (γ₂·(|o| + |t·d|) per
// component, Higham 2002 Lemma 3.1). A ray spawned from p itself can hit the surface it leaves
// at t ≈ 0 ("acne"). Moving the origin along the geometric normal, to the side the new ray goes,
// by the projection of that box on the normal, d = Σ|nᵢ|·errᵢ, puts it outside the box and so
// strictly on the right side of the true surface; each component is then rounded away from p so
// that the rounding of the move cannot undo it.
//
// When the tracer answering the spawned ray decides in single precision (Embree's float
// traversal in the fast and refined paths), the surface it sees differs from the double one by
// its own float rounding, so the box must also hold that: the tracer's FloatFrame
// (Tracer::float_frame, math/float_frame.h) says how large it is.

#include "engine/math/float_frame.h"
#include "engine/math/ray.h"

namespace raycastd::engine {

/// Per-component bound on |p − p_exact| for p = ray.at(hit.t), including the rounding of the
/// float tracer of `frame` (none when frame.scale is 0: a tracer that decides in double).
Vec3d hit_point_error(const Ray& ray, const Hit& hit, const FloatFrame& frame);

/// The origin for a ray leaving p (error `p_err`) in direction `w`: p moved along the unit
/// geometric normal `n`, to the side of `w`, past the error box, rounded away from p.
Vec3d offset_ray_origin(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& w);

/// A ray leaving the hit in direction `w` (tmin 0, tmax ∞).
Ray spawn_ray(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& w);

/// A shadow ray from the hit towards the point `target` (a point light): the direction is
/// target − origin and tmax is just below 1, so the segment stops short of the light itself.
Ray spawn_ray_to(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& target);

}  // namespace raycastd::engine
