#include "engine/accel/point_query.h"

namespace raycastd::engine {

void offer_primitive(const Scene& scene, std::uint32_t object, std::uint32_t prim, const Vec3d& p,
                     double max_distance, PointCandidates& c) {
    const Object& o = scene.objects[object];
    ClosestPoint cp;
    if (o.kind == ObjectKind::sphere) {
        cp = closest_point_on_sphere(o.sphere, p);
    } else {
        auto t = closest_point_on_triangle(o.mesh->triangle(prim), p);
        if (!t)
            return;
        cp = *t;
    }
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
    PointCandidates c;
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        const auto n = static_cast<std::uint32_t>(scene.objects[i].primitive_count());
        for (std::uint32_t k = 0; k < n; ++k)
            offer_primitive(scene, i, k, p, max_distance, c);
    }
    return finish_closest_point(scene, c);
}

}  // namespace raycastd::engine
