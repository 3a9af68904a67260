#pragma once
// Sphere and its ray intersection.
//
// Solves |o + t·d − c|² = r², i.e. a·t² + 2β·t + γ = 0 with f = o − c, a = d·d, β = f·d and
// γ = f·f − r², in the form of Haines, Günther & Akenine-Möller, "Precision Improvements for
// Ray/Sphere Intersection" (Ray Tracing Gems, ch. 7, 2019):
//   * the discriminant is computed as β² − a·γ = a·(r² − |f − (β/a)·d|²) (RTG eq. 7.5), where
//     f − (β/a)·d is the vector from the centre to the ray's closest approach: no catastrophic
//     cancellation between two huge squares when the sphere is far away;
//   * r² − |l|² is evaluated as (r − |l|)(r + |l|), which keeps its relative accuracy near
//     tangency;
//   * the roots are q/a and γ/q with q = −(β + sign(β)·√Δ) (Press et al., Numerical Recipes
//     §5.6), so neither root comes from subtracting two nearly equal numbers.

#include <cstdint>
#include <optional>

#include "engine/math/ray.h"

namespace raycastd::engine {

struct Sphere {
    Vec3d center;
    double radius = 1.0;
};

/// The real roots of the ray/sphere quadratic, ascending. count is 0 (miss), 1 (tangent: the
/// discriminant is exactly zero) or 2. Roots are not clipped to [tmin, tmax].
struct SphereRoots {
    int count = 0;
    double t[2] = {0.0, 0.0};
    double t_err = 0.0;  ///< a bound on the absolute error of each root
};

/// Both roots of the quadratic for any ray (direction must be non-zero and finite).
SphereRoots sphere_roots(const Sphere& s, const Ray& ray);

/// The first root in [ray.tmin, ray.tmax] as a Hit (object/primitive left for the caller), with
/// the outward unit normal; nullopt on a miss. With the origin inside the sphere this is the far
/// root. `want_normal = false` skips the normal and front-face computation.
std::optional<Hit> intersect_sphere(const Sphere& s, const Ray& ray, bool want_normal = true);

/// The outward unit normal at the point of the ray at parameter t, and whether the ray arrives
/// against it.
void sphere_normal(const Sphere& s, const Ray& ray, double t, Hit& hit);

}  // namespace raycastd::engine
