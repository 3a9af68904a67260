#include "engine/accel/scene_scan.h"

namespace raycastd::engine {

namespace {

/// The first of `r`'s roots in [tmin, tmax] (they are ascending), or none: intersect_sphere's
/// choice.
bool first_root_in_range(const SphereRoots& r, const Ray& ray, double& t) {
    for (int i = 0; i < r.count; ++i) {
        if (r.t[i] >= ray.tmin && r.t[i] <= ray.tmax) {
            t = r.t[i];
            return true;
        }
    }
    return false;
}

}  // namespace

SceneScan::SceneScan(const Scene& scene, bool fast) : fast_(fast) {
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        const Object& o = scene.objects[i];
        if (o.kind == ObjectKind::sphere) {
            prims_.push_back(Primitive{Triangle{}, o.sphere, i, 0, true, true});
            continue;
        }
        const TriangleMesh& mesh = *o.mesh;
        for (std::size_t p = 0; p < mesh.size(); ++p) {
            prims_.push_back(Primitive{mesh.triangle(p), Sphere{}, i, static_cast<std::uint32_t>(p),
                                       false, p + 1 == mesh.size()});
        }
    }
}

SphereRoots SceneScan::roots(const Sphere& s, const Ray& ray) const {
    return fast_ ? sphere_roots_fast(s, ray) : sphere_roots(s, ray);
}

std::optional<Hit> SceneScan::triangle(const Triangle& tri, const Ray& ray) const {
    return fast_ ? intersect_triangle_fast(tri, ray, /*want_normal=*/false)
                 : intersect_triangle(tri, ray, /*want_normal=*/false);
}

std::optional<Hit> SceneScan::closest(const Ray& ray_in, bool want_normal) const {
    // linear_closest's loop, flattened: `ray` carries the scene-wide best (tmax inclusive, so
    // an exact tie with a later object is still seen and `closer` decides it); a mesh's own
    // triangles narrow `local` and keep the lower index on an exact tie.
    Ray ray = ray_in;
    Ray local = ray_in;
    Hit best, mesh_best;
    const Primitive* winner = nullptr;
    const Primitive* mesh_winner = nullptr;
    bool new_object = true;
    for (const Primitive& p : prims_) {
        if (p.is_sphere) {
            new_object = true;
            const SphereRoots r = roots(p.sphere, ray);
            double t;
            if (first_root_in_range(r, ray, t)) {
                Hit h;
                h.t = t;
                h.t_err = r.t_err;
                h.object = p.object;
                h.primitive = 0;
                if (!winner || closer(h, best)) {
                    best = h;
                    winner = &p;
                    ray.tmax = t;
                }
            }
            continue;
        }
        if (new_object) {
            local = ray;
            mesh_winner = nullptr;
        }
        if (auto h = triangle(p.tri, local)) {
            if (!mesh_winner || h->t < mesh_best.t) {
                mesh_best = *h;
                mesh_best.object = p.object;
                mesh_best.primitive = p.index;
                mesh_winner = &p;
                local.tmax = h->t;
            }
        }
        new_object = p.last_of_object;
        if (p.last_of_object && mesh_winner && (!winner || closer(mesh_best, best))) {
            best = mesh_best;
            winner = mesh_winner;
            ray.tmax = best.t;
        }
    }
    if (!winner)
        return std::nullopt;
    if (want_normal) {
        if (winner->is_sphere)
            sphere_normal(winner->sphere, ray_in, best.t, best);
        else
            best.normal = triangle_normal(winner->tri);
    }
    return best;
}

bool SceneScan::any(const Ray& ray) const {
    for (const Primitive& p : prims_) {
        if (p.is_sphere) {
            double t;
            if (first_root_in_range(roots(p.sphere, ray), ray, t))
                return true;
        } else if (triangle(p.tri, ray)) {
            return true;
        }
    }
    return false;
}

}  // namespace raycastd::engine
