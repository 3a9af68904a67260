#include "engine/geometry/sphere.h"

#include <algorithm>
#include <cmath>

#include "engine/math/float_bounds.h"

namespace raycastd::engine {

SphereRoots sphere_roots(const Sphere& s, const Ray& ray) {
    SphereRoots out;
    const Vec3d f = ray.origin - s.center;
    const Vec3d& d = ray.direction;
    const double a = dot(d, d);
    const double beta = dot(f, d);
    const double gamma_c = dot(f, f) - s.radius * s.radius;

    // Δ/4 = a·(r − |l|)(r + |l|), l = f − (β/a)·d (RTG eq. 7.5).
    const Vec3d l = f - d * (beta / a);
    const double len_l = length(l);
    const double disc = a * ((s.radius - len_l) * (s.radius + len_l));
    if (!(disc >= 0.0)) return out;  // also rejects NaN

    // Error estimate: every quantity above is a short chain of roundings on numbers of size
    // |f|·|d|, so each root is known to a few ulps of the larger of |t| and the distance scale.
    const double scale = (length(f) + s.radius) / std::sqrt(a);
    out.t_err = gamma(12) * scale;

    if (disc == 0.0) {
        // Tangent: one root, at the closest approach. Reported once, deliberately.
        out.count = 1;
        out.t[0] = out.t[1] = -beta / a;
        return out;
    }
    const double q = -(beta + std::copysign(std::sqrt(disc), beta));
    double t0 = q / a;
    double t1 = gamma_c / q;  // q ≠ 0 here: |q| ≥ √disc > 0
    if (t0 > t1) std::swap(t0, t1);
    out.count = 2;
    out.t[0] = t0;
    out.t[1] = t1;
    return out;
}

void sphere_normal(const Sphere& s, const Ray& ray, double t, Hit& hit) {
    // (p − c)/r is exact for the points a reader checks by hand (the tutorial's (0, −1, −√3)/2
    // gives −0.5, not −0.5000000000000001); when rounding in p leaves it visibly off unit
    // length (far from the origin), normalise instead.
    const Vec3d pc = ray.origin - s.center + ray.direction * t;
    Vec3d n = pc / s.radius;
    const double len2 = dot(n, n);
    if (std::abs(len2 - 1.0) > 8.0 * kDoubleUnitRoundoff) n = normalize(pc);
    hit.normal = n;
    hit.front_face = dot(ray.direction, hit.normal) < 0.0;
}

std::optional<Hit> intersect_sphere(const Sphere& s, const Ray& ray, bool want_normal) {
    const SphereRoots r = sphere_roots(s, ray);
    for (int i = 0; i < r.count; ++i) {
        const double t = r.t[i];
        if (t >= ray.tmin && t <= ray.tmax) {
            Hit hit;
            hit.t = t;
            hit.t_err = r.t_err;
            hit.primitive = 0;
            if (want_normal) sphere_normal(s, ray, t, hit);
            return hit;
        }
    }
    return std::nullopt;
}

}  // namespace raycastd::engine
