#include "engine/accel/scene_scan.h"

#include <cmath>
#include <limits>

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
        1.0001 * (dot(n_err, aoa) + gamma(5) * dot(an, aoa) + dd_scale * max_abs(oa)) + 0x1p-1000;
    const double sd_err = 1.0001 * (dot(n_err, ad) + gamma(4) * dot(an, ad)) + 0x1p-1000;
    return (s > s_err && sd > sd_err) || (s < -s_err && sd < -sd_err);
}

SceneScan::SceneScan(const Scene& scene, bool fast) : fast_(fast) {
    std::uint32_t spheres = 0;
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        const Object& o = scene.objects[i];
        if (o.kind == ObjectKind::sphere) {
            const std::uint32_t k = spheres++;
            prims_.push_back(Primitive{Triangle{}, TrianglePlane{}, o.sphere, i, k, true, true});
            if (k % 2 == 0)
                spheres_.push_back(SpherePair{});
            SpherePair& pair = spheres_.back();
            const Sphere& s = o.sphere;
            pair.cx[k % 2] = s.center.x;
            pair.cy[k % 2] = s.center.y;
            pair.cz[k % 2] = s.center.z;
            pair.r2[k % 2] = s.radius * s.radius;
            // Below 2⁻¹⁰⁰⁰ r² has lost its relative precision (or is no radius at all): the
            // bound of sphere_candidates does not hold, and the kernels decide.
            if (k < 32 && pair.r2[k % 2] >= 0x1p-1000 && pair.r2[k % 2] <= 0x1p1000)
                cullable_ |= std::uint32_t{1} << k;
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

std::uint32_t SceneScan::sphere_candidates(const Ray& ray) const {
    // sphere_roots' own plain-double shortcut, two spheres at a time (SSE2 lanes, GCC's vector
    // extension), before any call: 89% of the sphere tests of the bench's tutorial_like render
    // at exact are lines that miss (counted 2026-12-04: 81 of 92 million), and those calls had
    // been a third of the render (perf). The discriminant a·r² − |f × d|² formed from the
    // rounded f = o − c is within 48u·(|f|²a + a·r²) of the exact one (sphere_roots: Higham
    // 2002, Lemma 3.1 on the cross product and the dot products), plus 2⁻⁹⁰⁰ for products that
    // underflow. Beyond 128u of that the exact discriminant is below −80u·a·(|f|² + r²): the
    // double-double discriminant of sphere_roots (a few u² of the same terms) is negative, and
    // so is sphere_roots_fast's r² − |l|² (within ~22u·|f|² + 2u·r² + u·|disc| of Δ/(4a)),
    // so both kernels find no root. A lane with an infinity or NaN anywhere is never ruled out.
    using v2d = double __attribute__((vector_size(16)));
    const double ox = ray.origin.x, oy = ray.origin.y, oz = ray.origin.z;
    const double dx = ray.direction.x, dy = ray.direction.y, dz = ray.direction.z;
    const double a = dx * dx + dy * dy + dz * dz;
    constexpr double kMax = std::numeric_limits<double>::max();
    // Roots before the origin are out of range only when the range starts at or after it.
    const bool behind_ok = ray.tmin >= 0.0;
    // Below 2⁻¹⁰²⁰, d·d has lost its relative precision to the subnormal grid, and a·r² (r²
    // up to 2¹⁰⁰⁰) with it: no line is ruled out (a helper's review found a hit at fast with
    // |d| ≈ 3e-162 and r = 1e100 that the test had ruled out).
    const auto a_normal = v2d{a, a} >= 0x1p-1020;
    std::uint32_t ruled_out = 0;
    for (std::size_t j = 0; j < spheres_.size() && j < 16; ++j) {
        const SpherePair& p = spheres_[j];
        const v2d fx = ox - v2d{p.cx[0], p.cx[1]};
        const v2d fy = oy - v2d{p.cy[0], p.cy[1]};
        const v2d fz = oz - v2d{p.cz[0], p.cz[1]};
        const v2d c0 = fy * dz - fz * dy;
        const v2d c1 = fz * dx - fx * dz;
        const v2d c2 = fx * dy - fy * dx;
        const v2d cc = c0 * c0 + c1 * c1 + c2 * c2;
        const v2d ar2 = a * v2d{p.r2[0], p.r2[1]};
        const v2d ff = fx * fx + fy * fy + fz * fz;
        const v2d bound = 128.0 * kDoubleUnitRoundoff * (ff * a + ar2) + 0x1p-900;
        // Lanes are −1 where the line certainly misses (all terms finite, so the comparisons
        // are false on a NaN or an overflow).
        auto miss = (ar2 - cc < -bound) & (bound <= kMax) & (cc <= kMax) & a_normal;
        if (behind_ok) {
            // Or where the sphere lies behind: the origin outside it (γ = |f|² − r² > 0) and
            // the ray moving away from its centre (β = f·d > 0). Both roots (−β ± √(β² − aγ))/a
            // are then negative, and the kernels' too: their γ and β keep those signs when
            // each clears its rounding (|f|² and r² within γ₃ and u; β within (γ₃ + u)·|f||d|
            // ≈ 4u·|f||d| of the exact f·d, so β² > 64u²·|f|²a leaves room), and neither forms
            // a root of another sign from them.
            const v2d r2 = {p.r2[0], p.r2[1]};
            const v2d beta = fx * dx + fy * dy + fz * dz;
            const v2d fa = ff * a;
            miss |=
                (ff - r2 > 8.0 * kDoubleUnitRoundoff * (ff + r2)) & (beta > 0.0) &
                (beta * beta > 64.0 * kDoubleUnitRoundoff * kDoubleUnitRoundoff * fa + 0x1p-900) &
                (fa <= kMax) & (ff <= kMax);
        }
        ruled_out |= (miss[0] ? std::uint32_t{1} : 0u) << (2 * j) |
                     (miss[1] ? std::uint32_t{1} : 0u) << (2 * j + 1);
    }
    return ~(ruled_out & cullable_);
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
    const std::uint32_t candidates = sphere_candidates(ray_in);
    for (const Primitive& p : prims_) {
        if (p.is_sphere) {
            new_object = true;
            if (!may_hit(candidates, p.index))
                continue;
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
    const std::uint32_t candidates = sphere_candidates(ray);
    for (const Primitive& p : prims_) {
        if (p.is_sphere) {
            if (may_hit(candidates, p.index) &&
                first_hit_of_roots(p.sphere, ray, roots(p.sphere, ray), false))
                return true;
        } else if (!p.plane.left_behind(ray) && triangle(p.tri, ray)) {
            return true;
        }
    }
    return false;
}

}  // namespace raycastd::engine
