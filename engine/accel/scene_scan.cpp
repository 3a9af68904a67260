#include "engine/accel/scene_scan.h"

#include "engine/math/float_bounds.h"

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
            prims_.push_back(Primitive{Triangle{}, Vec3d{}, Vec3d{}, o.sphere, i, 0, true, true});
            continue;
        }
        const TriangleMesh& mesh = *o.mesh;
        for (std::size_t p = 0; p < mesh.size(); ++p) {
            const Triangle t = mesh.triangle(p);
            const Vec3d e1 = t.b - t.a, e2 = t.c - t.a;
            // As plane_t's bound: each edge, product and difference rounded once (γ₄ of the
            // magnitudes; γ₅ covers their own rounding; Higham 2002, Lemma 3.1).
            const Vec3d a1 = abs(e1), a2 = abs(e2);
            const Vec3d n_err =
                gamma(5) * Vec3d{a1.y * a2.z + a1.z * a2.y, a1.z * a2.x + a1.x * a2.z,
                                 a1.x * a2.y + a1.y * a2.x};
            prims_.push_back(Primitive{t, cross(e1, e2), n_err, Sphere{}, i,
                                       static_cast<std::uint32_t>(p), false, p + 1 == mesh.size()});
        }
    }
}

bool SceneScan::leaves_plane(const Primitive& p, const Ray& ray) {
    // s = n·(o − a) and n·d, each within its error bound of the exact triangle's: the rounded
    // normal's error times the other factor, and the rounding of o − a and of the dot products
    // (γ₅ of the magnitudes, with room for the bounds' own rounding). Both beyond their bounds
    // and of one sign: the line crosses the plane at t = −s/(n·d) < 0, strictly before the
    // origin, where plane_t's t (about an ulp) and the fast kernel's (t − t_err ≥ tmin asked)
    // cannot reach a tmin ≥ 0. A ray spawned off a floor, or looking up from above it, skips
    // Woop's test of the floor's triangles.
    if (!(ray.tmin >= 0.0))
        return false;
    const Vec3d oa = ray.origin - p.tri.a;
    const Vec3d& d = ray.direction;
    const double s = dot(p.n, oa), sd = dot(p.n, d);
    const Vec3d an = abs(p.n), aoa = abs(oa), ad = abs(d);
    const double s_err = 1.0001 * (dot(p.n_err, aoa) + gamma(5) * dot(an, aoa));
    const double sd_err = 1.0001 * (dot(p.n_err, ad) + gamma(4) * dot(an, ad));
    return (s > s_err && sd > sd_err) || (s < -s_err && sd < -sd_err);
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
        // leaves_plane: a miss, without Woop's test.
        const std::optional<Hit> h = leaves_plane(p, local) ? std::nullopt : triangle(p.tri, local);
        if (h && (!mesh_winner || h->t < mesh_best.t)) {
            mesh_best = *h;
            mesh_best.object = p.object;
            mesh_best.primitive = p.index;
            mesh_winner = &p;
            local.tmax = h->t;
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
        } else if (!leaves_plane(p, ray) && triangle(p.tri, ray)) {
            return true;
        }
    }
    return false;
}

}  // namespace raycastd::engine
