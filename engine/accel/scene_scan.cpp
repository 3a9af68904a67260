#include "engine/accel/scene_scan.h"

#include <cmath>

#include "engine/math/float_bounds.h"

namespace raycastd::engine {

TrianglePlane TrianglePlane::of(const Triangle& tri) {
    TrianglePlane p;
    p.a = tri.a;
    const Vec3d e1 = tri.b - tri.a, e2 = tri.c - tri.a;
    p.n = cross(e1, e2);
    // plane_t's bound on the rounded normal (cross_magnitudes).
    const Vec3d m = cross_magnitudes(e1, e2);
    p.n_err = gamma(5) * m;
    const Vec3d an = abs(p.n);
    p.dd_scale = 0x1p-96 * (an.x + an.y + an.z + m.x + m.y + m.z);
    // A product that underflows breaks the relative bounds above (and the kernels' own): such
    // a triangle (edge components below ~1e-150) is never skipped. A zero factor is exact.
    const Vec3d a1 = abs(e1), a2 = abs(e2);
    const double f1[6] = {a1.y, a1.z, a1.z, a1.x, a1.x, a1.y};
    const double f2[6] = {a2.z, a2.y, a2.x, a2.z, a2.y, a2.x};
    p.usable = std::isfinite(p.dd_scale);
    for (int k = 0; k < 6; ++k)
        p.usable = p.usable && (f1[k] == 0.0 || f2[k] == 0.0 || f1[k] * f2[k] >= 0x1p-1000);
    return p;
}

bool TrianglePlane::left_behind(const Ray& ray) const {
    // s = n·(o − a) and n·d, each within its error bound of the exact triangle's: the rounded
    // normal's error times the other factor, and the rounding of o − a and of the dot products
    // (γ₅ of the magnitudes, with room for the bounds' own rounding). Beyond that, s must clear
    // plane_t's double-double resolution (its numerator n·(v − o), v the corner nearest the
    // origin, is exact only to ~u² of Σ|n||v − o|, and |v − o|∞ ≤ |a − o|∞: a numerator below
    // that rounds to 0 and gives t = 0, a hit at tmin = 0), and both 2⁻¹⁰⁰⁰ (no underflowed
    // terms). Both beyond their bounds and of one sign: the line crosses the plane at
    // t = −s/(n·d) < 0, strictly before the origin, and plane_t's t keeps that sign (its
    // plain-double path is within u·|t|/8 of it, its double-double path has the numerator's
    // sign), as the fast kernel's t − t_err does: neither reports a hit at tmin ≥ 0.
    if (!usable || !(ray.tmin >= 0.0))
        return false;
    const Vec3d oa = ray.origin - a;
    const Vec3d& d = ray.direction;
    const double s = dot(n, oa), sd = dot(n, d);
    const Vec3d an = abs(n), aoa = abs(oa), ad = abs(d);
    const double s_err =
        1.0001 * (dot(n_err, aoa) + gamma(5) * dot(an, aoa) + dd_scale * max_component(aoa)) +
        0x1p-1000;
    const double sd_err = 1.0001 * (dot(n_err, ad) + gamma(4) * dot(an, ad)) + 0x1p-1000;
    return (s > s_err && sd > sd_err) || (s < -s_err && sd < -sd_err);
}

SceneScan::SceneScan(const Scene& scene, bool fast) : fast_(fast) {
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        const Object& o = scene.objects[i];
        if (o.kind == ObjectKind::sphere) {
            prims_.push_back(Primitive{Triangle{}, TrianglePlane{}, o.sphere, i, 0, true, true});
            continue;
        }
        const TriangleMesh& mesh = *o.mesh;
        for (std::size_t p = 0; p < mesh.size(); ++p) {
            const Triangle t = mesh.triangle(p);
            prims_.push_back(Primitive{t, TrianglePlane::of(t), Sphere{}, i,
                                       static_cast<std::uint32_t>(p), false, p + 1 == mesh.size()});
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
            // intersect_sphere without the normal (filled below for the winner).
            if (auto h = first_hit_of_roots(p.sphere, ray, roots(p.sphere, ray), false)) {
                h->object = p.object;
                if (!winner || closer(*h, best)) {
                    best = *h;
                    winner = &p;
                    ray.tmax = h->t;
                }
            }
            continue;
        }
        if (new_object) {
            local = ray;
            mesh_winner = nullptr;
        }
        // A plane left behind: a miss, without Woop's test.
        const std::optional<Hit> h =
            p.plane.left_behind(local) ? std::nullopt : triangle(p.tri, local);
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
            if (first_hit_of_roots(p.sphere, ray, roots(p.sphere, ray), false))
                return true;
        } else if (!p.plane.left_behind(ray) && triangle(p.tri, ray)) {
            return true;
        }
    }
    return false;
}

}  // namespace raycastd::engine
