#include "engine/shade/spawn.h"

#include <cmath>

#include "engine/math/float_bounds.h"

namespace raycastd::engine {

Vec3d hit_point_error(const Ray& ray, const Hit& hit, const FloatFrame& frame) {
    const Vec3d td = ray.direction * hit.t;
    // The error carried by t, then the rounding of t·d and of o + t·d (two roundings).
    const Vec3d err = abs(ray.direction) * hit.t_err + (abs(ray.origin) + abs(td)) * gamma(2);
    return frame.scale > 0.0 ? err + float_tracer_error(ray.origin + td, frame) : err;
}

Vec3d float_tracer_error(const Vec3d& p, const FloatFrame& frame) {
    if (!(frame.scale > 0.0))
        return {};
    // A float tracer rounds the spawned origin (relative to its centre) and its own copy of the
    // surface; its t carries γ_f(12) of the scene scale (fast_hit in
    // engine/accel/embree/float_ray.h). γ_f(16) of (distance to the centre + scale) bounds both,
    // with a margin.
    const double f = gamma_float(16) * (length(p - frame.center) + frame.scale);
    return {f, f, f};
}

}  // namespace raycastd::engine
