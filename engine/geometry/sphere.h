#pragma once
// Sphere and its ray intersection.
//
// Solves |o + t·d − c|² = r², i.e. a·t² + 2β·t + γ = 0 with f = o − c, a = d·d, β = f·d and
// γ = f·f − r², following Haines, Günther & Akenine-Möller, "Precision Improvements for
// Ray/Sphere Intersection" (Ray Tracing Gems, ch. 7, 2019), evaluated in double-double:
//   * f = o − c is formed exactly (Knuth's TwoSum), and from 2²⁶ radii away f × d from the
//     exact parts of its products (SumK, Ogita, Rump & Oishi 2005), so a far origin costs
//     nothing;
//   * the discriminant is a·r² − |f × d|² (= β² − a·γ by Lagrange's identity; RTG eq. 7.5
//     writes it a·(r² − |l|²) with l the closest approach), so no difference of two huge
//     squares is formed, and in double-double (TwoProduct with std::fma; Dekker 1971, Ogita,
//     Rump & Oishi 2005) its cancellation near tangency leaves ~u² of the operands' size: a ray
//     tangent within 1e-12 still gets every root digit;
//   * the roots are t_c ∓ h around the closest approach t_c = −β/a, h = √(Δ/4)/a (the form
//     of the worked solution: 9 ∓ √3 for the tutorial), where that difference cannot cancel;
//     otherwise the near root is γ/q with q = −(β + sign(β)·√Δ) (Press et al., Numerical
//     Recipes §5.6), with γ in double-double too, so an origin on (or a rounding away from) the
//     surface gets its tiny root right.
// Each root is rounded from double-double at most three times: within 2 ulps of the exact
// root (measured against a quad-precision reference in tests/stress; docs/accuracy.md).

#include <cmath>
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
    /// No roots because the sphere is smaller than 2⁻⁹⁰⁰ of its distance or of the origin's
    /// coordinates (sphere_roots' tiny-radius rescaling gives up): below double's resolution
    /// there, it is taken as missed whatever the line does. Set by sphere_roots only, for the
    /// worked solution (explain), which says so rather than "no real roots". Not set where the
    /// lengths pass 2⁵⁰⁰ and are scaled down first: a radius that small then rounds to 0, and
    /// the sphere is a point, hit (as a tangent) only by a line through its centre exactly.
    bool unresolved = false;
    double t[2] = {0.0, 0.0};
    double t_err = 0.0;  ///< a bound on the absolute error of each root
};

/// Both roots of the quadratic for any ray (direction must be non-zero and finite).
SphereRoots sphere_roots(const Sphere& s, const Ray& ray);

/// The same roots in plain double, for the `fast` precision: the stable form of Haines et al.
/// (Ray Tracing Gems, 2019, ch. 7: the discriminant from the closest-approach vector, the near
/// root from q) without double-double. Several times cheaper than sphere_roots when the ray
/// hits; relative error a few ulps of the distance scale (|o − c| + r)/|d| away from tangency,
/// growing as √u near it. t_err bounds both.
SphereRoots sphere_roots_fast(const Sphere& s, const Ray& ray);

/// sphere_hits with sphere_roots_fast.
int sphere_hits_fast(const Sphere& s, const Ray& ray, Hit out[2]);

/// The first root in [ray.tmin, ray.tmax] as a Hit (object/primitive left for the caller), with
/// the outward unit normal; nullopt on a miss. With the origin inside the sphere this is the far
/// root. `want_normal = false` skips the normal and front-face computation.
std::optional<Hit> intersect_sphere(const Sphere& s, const Ray& ray, bool want_normal = true);

/// The index of the first of `r`'s roots in [ray.tmin, ray.tmax], or −1. A root that overflowed
/// double (a direction 1e-10 long towards a sphere 1e300 away: t ≈ 1e310) is no hit, even with
/// the default tmax = +inf: its t cannot be answered (JSON has no inf, and the binary answer's
/// t = +inf means a miss).
inline int first_root_in_range(const SphereRoots& r, const Ray& ray) {
    for (int i = 0; i < r.count; ++i) {
        if (r.t[i] >= ray.tmin && r.t[i] <= ray.tmax && std::isfinite(r.t[i]))
            return i;
    }
    return -1;
}

/// intersect_sphere's answer from roots already found (sphere_roots or sphere_roots_fast):
/// the first of them in [ray.tmin, ray.tmax] as a Hit.
std::optional<Hit> first_hit_of_roots(const Sphere& s, const Ray& ray, const SphereRoots& r,
                                      bool want_normal);

/// Every root in [ray.tmin, ray.tmax] as a Hit (t, t_err, primitive 0, outward normal and
/// front_face; object left for the caller), ascending; returns how many (0, 1 or 2).
int sphere_hits(const Sphere& s, const Ray& ray, Hit out[2]);

/// From 2²⁰ radii away sphere_normal forms the normal from the closest approach: there the plain
/// form's rounding, u·|o − c| ≈ 2⁻³³ of the radius, would start to show in the normal's digits.
inline constexpr double kNormalFarRadii = 0x1p20;

/// The outward unit normal at the point of the ray at parameter t, and whether the ray arrives
/// against it. Which root t is, where that matters, is told by t itself: see the overload.
void sphere_normal(const Sphere& s, const Ray& ray, double t, Hit& hit);
/// Which of `r`'s roots root i is: −1 the near one, +1 the far one, 0 a single (tangent) root.
int root_side(const SphereRoots& r, int i);
/// sphere_normal at a root whose side (root_side) is known: from far away (2²⁰ radii on) the
/// normal is formed from the closest approach and the half-chord, and both roots of a
/// near-tangent line may round to one t (sphere_hits and first_hit_of_roots pass it).
void sphere_normal(const Sphere& s, const Ray& ray, double t, int side, Hit& hit);
/// The parameter of the ray's point nearest the centre, −(f·d)/(d·d) in double: where a far
/// ray's moved copy lies within its error of tangency, a sphere's place along it.
double sphere_closest_approach(const Sphere& s, const Ray& ray);

}  // namespace raycastd::engine
