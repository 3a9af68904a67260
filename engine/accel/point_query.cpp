#include "engine/accel/point_query.h"

#include <algorithm>

namespace raycastd::engine {

namespace {

/// The squared distance from p to the triangle's bounding box (0 inside it). Written with
/// std::min/std::max: Vec3's min/max use std::fmin/fmax, which GCC calls out of line.
double box_distance2(const Triangle& t, const Vec3d& p) {
    double d2 = 0;
    for (std::size_t k = 0; k < 3; ++k) {
        const double lo = std::min(t.a[k], std::min(t.b[k], t.c[k]));
        const double hi = std::max(t.a[k], std::max(t.b[k], t.c[k]));
        const double g = std::max(lo - p[k], std::max(p[k] - hi, 0.0));
        d2 += g * g;
    }
    return d2;
}

}  // namespace

void offer_primitive(const Scene& scene, std::uint32_t object, std::uint32_t prim, const Vec3d& p,
                     double max_distance, PointCandidates& c) {
    const Object& o = scene.objects[object];
    ClosestPoint cp;
    if (o.kind == ObjectKind::sphere) {
        cp = closest_point_on_sphere(o.sphere, p);
    } else {
        const Triangle tri = o.mesh->triangle(prim);
        // The distance to the triangle's box bounds the distance to the triangle from below:
        // a triangle whose box is already beyond reach is skipped before the exact test (Embree
        // hands over whole leaves; from afar most of a leaf's triangles are out of reach).
        if (box_distance2(tri, p) > c.cull_distance() * c.cull_distance())
            return;
        auto t = closest_point_on_triangle(tri, p);
        if (!t)
            return;
        cp = *t;
    }
    offer_closest_point(cp, object, prim, max_distance, c);
}

void offer_closest_point(const ClosestPoint& cp, std::uint32_t object, std::uint32_t prim,
                         double max_distance, PointCandidates& c) {
    if (!(cp.distance <= max_distance))
        return;
    PointHit h;
    h.point = cp.point;
    h.distance = cp.distance;
    h.err = cp.err;
    h.object = object;
    h.primitive = prim;
    h.u = cp.u;
    h.v = cp.v;
    c.offer(h);
}

std::optional<PointHit> finish_closest_point(const Scene& scene, const PointCandidates& c) {
    PointHit h = c.winner();
    if (!h.valid())
        return std::nullopt;
    const Object& o = scene.objects[h.object];
    if (o.kind == ObjectKind::sphere) {
        h.normal = normalize(h.point - o.sphere.center);
    } else {
        h.normal = triangle_normal(o.mesh->triangle(h.primitive));
    }
    return h;
}

std::optional<PointHit> linear_closest_point(const Scene& scene, const Vec3d& p,
                                             double max_distance) {
    PointCandidates c(candidate_err_bound(p, scene.bounds()));
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        const auto n = static_cast<std::uint32_t>(scene.objects[i].primitive_count());
        for (std::uint32_t k = 0; k < n; ++k)
            offer_primitive(scene, i, k, p, max_distance, c);
    }
    return finish_closest_point(scene, c);
}

}  // namespace raycastd::engine
