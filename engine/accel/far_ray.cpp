#include "engine/accel/far_ray.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "engine/geometry/triangle.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine {

MoveResult move_near_ball(const Vec3d& centre, double radius, const Ray& ray, MovedRay& m) {
    const Vec3d& o = ray.origin;
    // The direction scaled by a power of two to unit size, exactly: the line is the same and
    // its parameter τ = t·2^e (MovedRay::exp). A direction whose |d|² left double's normal range
    // (shorter than ~1e-135 or longer than ~1e135, which the API accepts) had not been moved, and
    // its far rays kept the far kernels' answers (a line through a sphere's centre from 2^60
    // away, direction 2^-460 per axis, missed: a helper's review).
    const double dmax = max_abs(ray.direction);
    if (!(dmax > 0.0) || !std::isfinite(dmax))
        return MoveResult::not_possible;
    m.exp = std::ilogb(dmax);
    const Vec3d d = ray.direction * std::ldexp(1.0, -m.exp);
    const double d2 = dot(d, d);
    if (!(d2 >= 0x1p-900 && d2 <= 0x1p900) || !(radius > 0.0) || !std::isfinite(radius))
        return MoveResult::not_possible;
    const double dlen = std::sqrt(d2);
    // The point of the line at parameter `shift`, relative to the centre, in double-double
    // ((o − centre) + shift·d: TwoSum and TwoProduct are exact, the sums off by a few u² of the
    // terms: Ogita, Rump & Oishi 2005), rounded to double.
    const auto point = [&](const dd::DD& shift) {
        Vec3d q;
        for (std::size_t k = 0; k < 3; ++k) {
            const dd::DD p =
                dd::add(dd::add(dd::two_sum(o[k], -centre[k]), dd::two_prod(d[k], shift.hi)),
                        dd::two_prod(d[k], shift.lo));
            q[k] = p.hi + p.lo;
        }
        return q;
    };
    // The parameter of the line's point nearest the centre, (centre − o)·d/|d|², is known to a
    // few u of itself: from 1e16 scene sizes away that is thousands of scene sizes. So the point
    // it gives is measured, and the step to the nearest point taken again from there, each step
    // a few u of the last one's distance, the shift summed in double-double. Beyond ~1e30 scene
    // sizes double-double cannot hold the shift finely enough to come within the scene (nor the
    // line's place within it): not possible, and the caller keeps the ray as it is.
    dd::DD shift{dot(centre - o, d) / d2, 0.0};
    Vec3d q = point(shift);
    // Converged when the step is below 2⁻²⁰ of the distance to the centre, or below what the
    // double-double point itself resolves (a few u² of |o| and |shift·d|).
    const auto resolution = [&] {
        return 16.0 * kDoubleUnitRoundoff * kDoubleUnitRoundoff *
               (max_abs(o) + max_abs(centre) + dlen * std::abs(shift.hi));
    };
    bool converged = false;
    for (int step = 0; step < 6 && is_finite(q); ++step) {
        const double ds = -dot(q, d) / d2;
        if (std::abs(ds) * dlen <= 0x1p-20 * (scaled_length(q) + radius) + resolution()) {
            converged = true;
            break;
        }
        shift = dd::add(shift, dd::DD{ds, 0.0});
        q = point(shift);
    }
    if (!converged || !std::isfinite(shift.hi))
        return MoveResult::not_possible;
    // The moved origin's distance from the exact line: the double-double sums' few u² of the
    // terms and the rounding of q (u per coordinate; √3 < 1.8 for the length). In the centre's
    // frame: placed in world coordinates it would round by u·|centre| more, which for a scene
    // far from the world origin exceeds its own small triangles (a helper's probe: lines
    // through a point 1e-6 inside a triangle at 2^33 missed it).
    const double terms =
        max_abs(o) + max_abs(centre) + max_abs(d) * (std::abs(shift.hi) + std::abs(shift.lo));
    const auto line_err = [&](const Vec3d& at) {
        return 1.8 * (8.0 * kDoubleUnitRoundoff * kDoubleUnitRoundoff * terms +
                      kDoubleUnitRoundoff * max_abs(at));
    };
    // q is now the line's point nearest the centre: if the line passes farther than the padded
    // bounds' radius it meets nothing. The slab test, widened by γ₃ of a t of ~1e16 scene sizes,
    // had let such lines through, and they were answered by the far kernels (wrongly: a line
    // 22 units from a unit icosphere hit it) or the linear scan (a helper's review).
    if (scaled_length(q) > radius * (1.0 + 0x1p-20) + line_err(q))
        return MoveResult::misses;
    // Back two radii, before the padded bounds (an origin inside them would miss what lies
    // behind it only through tmin', which moves with it; starting outside keeps the float ray's
    // set-up the ordinary one).
    shift = dd::add(shift, dd::DD{-2.0 * radius / dlen, 0.0});
    q = point(shift);
    if (!is_finite(q) || !(max_abs(q) <= 4.0 * radius))
        return MoveResult::not_possible;
    m.shift = shift;
    m.ray.origin = q;  // relative to the centre (RayFrame::centre)
    m.ray.direction = d;
    // The range moves with the origin (tmin − shift rounds once: a hit within an ulp of the
    // client's far tmin or tmax, thousands of scene sizes at this distance, may go either way).
    // An end whose τ leaves double's range goes to ±inf or rounds towards 0 (MovedRay::moved_t),
    // which changes no answer: every crossing near the scene has a τ of shift plus a few radii,
    // finite and far from 0. Such ends had made the ray not movable: a tmax of 1e308 (clients
    // send it for "unbounded", JSON having no infinity) on a direction longer than 2 lost every
    // hit of a far ray, in every mode and precision (a helper's review).
    m.ray.tmin = m.moved_t(ray.tmin);
    // An unbounded ray ends at the largest double: a crossing past it overflows the client's t
    // and is no hit (sphere.h, first_root_in_range), but on the moved ray its t is finite, and
    // `any` had answered true where `closest` found nothing (a helper's review). Where that end
    // is out of the moved ray's range, no client t can overflow, and +inf stays.
    const bool unbounded_end = std::isinf(ray.tmax) && ray.tmax > 0.0 &&
                               std::isfinite(std::ldexp(std::numeric_limits<double>::max(), m.exp));
    m.ray.tmax = m.moved_t(unbounded_end ? std::numeric_limits<double>::max() : ray.tmax);
    m.line_err = line_err(q);
    if (!std::isfinite(m.line_err) || std::isnan(m.ray.tmin) || std::isnan(m.ray.tmax))
        return MoveResult::not_possible;
    return MoveResult::moved;
}

double MovedRay::moved_t(double t) const {
    // τ = t·2^exp is exact unless it leaves double's range: then it is ±inf (beyond every
    // crossing near the scene, whose τ is finite) or rounds towards 0 (far before them).
    const double tau = std::ldexp(t, exp);
    if (std::isinf(tau))
        return tau;
    const dd::DD r = dd::sub(dd::DD{tau, 0.0}, shift);
    return r.hi + r.lo;
}

double MovedRay::tau_of(double t_moved) const {
    const dd::DD t = dd::add(shift, dd::DD{t_moved, 0.0});
    return t.hi + t.lo;
}

MoveResult move_near_ball_world(const Vec3d& centre, double radius, const Ray& ray, MovedRay& out) {
    const MoveResult r = move_near_ball(centre, radius, ray, out);
    if (r != MoveResult::moved)
        return r;
    const Vec3d world = centre + out.ray.origin;
    out.ray.origin = world;
    out.line_err += 1.8 * kDoubleUnitRoundoff * max_abs(world);
    if (!is_finite(world) || !std::isfinite(out.line_err))
        return MoveResult::not_possible;
    return MoveResult::moved;
}

SceneBall scene_ball(const Scene& scene) {
    SceneBall b;
    const Bounds3 bounds = scene.bounds();
    if (bounds.empty())
        return b;
    b.centre = 0.5 * (bounds.lo + bounds.hi);
    const double half = 0.5 * scaled_length(bounds.hi - bounds.lo);
    b.radius = half * (1.0 + 0x1p-20) + 2.0 * kDoubleUnitRoundoff * max_abs(b.centre) + 0x1p-1000;
    b.usable = is_finite(b.centre) && std::isfinite(b.radius) && b.radius > 0.0;
    if (b.usable)
        b.far_reach = kFarRadii * std::max(b.radius, max_abs(b.centre));
    return b;
}

void moved_back(const Scene& scene, const MovedRay& m, Hit& h) {
    // The moved line is the ray's translated by at most m.line_err (same direction), which
    // moves a plane's crossing by |n·δ|/|n·d| ≤ line_err/|n̂·d|: a grazing hit moves far along
    // the ray. On a sphere the chord's ends move by at most δ + √(2rδ + δ²) (the half-chord
    // √(r² − ρ²) changes by at most √(|Δρ²|)), finite even for a tangent ray. Then the rounding
    // of tau_of, all in the moved ray's units (τ), scaled back to t's by 2^-exp, exactly.
    const Object& o = scene.objects[h.object];
    const double dlen = length(m.ray.direction);
    const double delta = m.line_err;
    double shift_bound;
    if (o.kind == ObjectKind::sphere) {
        const double r = o.sphere.radius;
        // √δ·√(2r + δ) rather than √(2rδ + δ²), whose δ² overflowed from ~1e185 away (t_err
        // inf for a unit sphere seen from 1e190: a helper's review).
        shift_bound = (delta + std::sqrt(delta) * std::sqrt(2.0 * r + delta)) / dlen;
    } else {
        const double nd =
            std::abs(dot(triangle_normal(o.mesh->triangle(h.primitive)), m.ray.direction));
        shift_bound = nd > 0.0 ? delta / nd : std::numeric_limits<double>::infinity();
    }
    const double tau = m.tau_of(h.t);
    const double tau_err = (h.t_err + shift_bound) * (1.0 + 4.0 * kDoubleUnitRoundoff) +
                           kDoubleUnitRoundoff * std::abs(tau);
    h.t = std::ldexp(tau, -m.exp);
    h.t_err = std::ldexp(tau_err, -m.exp);
}

Hit sphere_on_moved(const Sphere& s, const MovedRay& m, const Ray& moved_ray, const Hit& client,
                    int i, int n, const Hit* on_moved, int n_moved) {
    Hit h = client;
    if (n_moved == n) {
        h.t = on_moved[i].t;
        h.t_err = on_moved[i].t_err;
    } else {
        // Within the half-chord at the closest approach of either root: the move's bound for a
        // sphere (moved_back), in the moved ray's units.
        h.t = sphere_closest_approach(s, moved_ray);
        const double delta = m.line_err;
        h.t_err = (delta + std::sqrt(delta) * std::sqrt(2.0 * s.radius + delta)) /
                      length(moved_ray.direction) +
                  kDoubleUnitRoundoff * std::abs(h.t);
    }
    return h;
}

void sort_and_merge_on_moved(const std::vector<Hit>& moved, std::vector<Hit>& out) {
    std::vector<std::size_t> order(moved.size());
    for (std::size_t k = 0; k < order.size(); ++k)
        order[k] = k;
    // Stable: a sphere's two roots placed at one t (sphere_on_moved) tie by `closer`, and come
    // in the order they were appended, entry first (std::sort had swapped them: a review).
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return closer(moved[a], moved[b]); });
    const std::vector<std::size_t> kept =
        kept_after_edge_merge(order, [&](std::size_t k) -> const Hit& { return moved[k]; });
    std::vector<Hit> sorted;
    sorted.reserve(kept.size());
    for (const std::size_t k : kept) {
        // A crossing whose t overflowed double on the way back (moved_back: 1e300 away along a
        // direction 1e-10 long) is no hit, as in the kernels (sphere.h, first_root_in_range).
        if (std::isfinite(out[k].t))
            sorted.push_back(out[k]);
    }
    out.swap(sorted);
}

}  // namespace raycastd::engine
