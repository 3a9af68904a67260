#include "engine/shade/spawn.h"

#include <cmath>

#include "engine/math/float_bounds.h"

namespace raycastd::engine {

Vec3d hit_point_error(const Ray& ray, const Hit& hit, const FloatFrame& frame) {
    const Vec3d td = ray.direction * hit.t;
    // The error carried by t, then the rounding of t·d and of o + t·d (two roundings).
    Vec3d err = abs(ray.direction) * hit.t_err + (abs(ray.origin) + abs(td)) * gamma(2);
    if (frame.scale > 0.0) {
        // A float tracer rounds the spawned origin (relative to its centre) and its own copy of
        // the surface; its t carries γ_f(12) of the scene scale (fast_hit in
        // engine/accel/embree/float_ray.h). γ_f(16) of (distance to the centre + scale) bounds
        // both, with a margin.
        const Vec3d p = ray.origin + td;
        const double f = gamma_float(16) * (length(p - frame.center) + frame.scale);
        err += Vec3d{f, f, f};
    }
    return err;
}

namespace {

/// p + offset rounded once more away from p, so that the addition cannot land back inside the
/// error box.
double moved_away(double p, double offset) {
    const double po = p + offset;
    return offset > 0.0 ? next_up(po) : offset < 0.0 ? next_down(po) : po;
}

}  // namespace

Vec3d offset_ray_origin(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& w) {
    const double d = dot(abs(n), p_err);
    Vec3d offset = n * d;
    if (dot(w, n) < 0.0)
        offset = -offset;
    // Component by component, not through an indexed loop over a Vec3d: GCC kept that one in
    // memory, and reading it back whole after writing one component stalled store forwarding
    // (a third of spawn_ray's samples on the Duck, perf annotate).
    return {moved_away(p.x, offset.x), moved_away(p.y, offset.y), moved_away(p.z, offset.z)};
}

Ray spawn_ray(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& w) {
    Ray r;
    r.origin = offset_ray_origin(p, p_err, n, w);
    r.direction = w;
    return r;
}

Ray spawn_ray_to(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& target) {
    Ray r;
    r.origin = offset_ray_origin(p, p_err, n, target - p);
    r.direction = target - r.origin;
    // Stop short of the light: something exactly at the light's position does not shadow it.
    r.tmax = 1.0 - gamma(4);
    return r;
}

}  // namespace raycastd::engine
