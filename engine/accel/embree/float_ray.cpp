#include "engine/accel/embree/float_ray.h"

#include <limits>

#include "engine/math/double_double.h"

namespace raycastd::engine::embree {

bool clip_to_bounds(const Impl& a, const Ray& ray, double& t0, double& t1) {
    return clip_to_bounds(a.padded_bounds, ray, t0, t1);
}

bool clip_to_bounds(const Bounds3& bounds, const Ray& ray, double& t0, double& t1) {
    // Slab test in double (Kay & Kajiya 1986) against the padded bounds.
    t0 = ray.tmin;
    t1 = ray.tmax;
    for (std::size_t k = 0; k < 3; ++k) {
        const double o = ray.origin[k], d = ray.direction[k];
        const double lo = bounds.lo[k], hi = bounds.hi[k];
        if (d == 0.0) {
            if (o < lo || o > hi)
                return false;
            continue;
        }
        // One reciprocal rather than two divisions (the slab test was 7% of a refined batch,
        // perf): (lo − o)·(1/d) rounds three times, which the widening below covers.
        const double inv = 1.0 / d;
        double ta = (lo - o) * inv, tb = (hi - o) * inv;
        if (ta > tb)
            std::swap(ta, tb);
        // Widen by a few ulps: the subtraction, reciprocal and product round (γ₃), and a hit at
        // the slab's edge must survive.
        t0 = std::max(t0, ta - gamma(3) * std::abs(ta));
        t1 = std::min(t1, tb + gamma(3) * std::abs(tb));
    }
    return t0 <= t1;
}

namespace {

/// A ray prepare_ray does not trace in float: an empty segment (a unit direction, tfar −1), and
/// an origin_err that unplaced() recognises, which sends it to the exact answer.
void leave_unplaced(RayContext& c, FloatRay& f) {
    c.origin_err = std::numeric_limits<double>::infinity();
    c.far = true;
    f = FloatRay{};
    f.dir_z = 1.0f;
    f.tfar = -1.0f;
}

}  // namespace

bool prepare_ray(const Impl& a, const Ray& ray, RayStart start, RayContext& c, FloatRay& f,
                 RayFrame frame) {
    // A ray relative to the centre is clipped against the bounds relative to it, and its
    // origin is already what the float ray starts from.
    const bool relative = frame == RayFrame::centre;
    const Vec3d base = relative ? Vec3d{} : a.center;
    double t0, t1;
    if (!clip_to_bounds(relative ? a.padded_bounds_rel : a.padded_bounds, ray, t0, t1))
        return false;
    c.ray = &ray;
    c.frame = relative ? &a.center : nullptr;
    c.far = false;
    double dlen = length(ray.direction);
    if (!(dlen > 0x1p-500 && dlen < 0x1p500))
        dlen = scaled_length(ray.direction);  // |d|² over- or underflowed (a direction 1e160 long)
    c.len = dlen * a.unit;                    // float t in Embree's frame (Impl::unit)
    c.margin = 4.0 * a.pad * a.unit;
    c.shift = start == RayStart::backed_off ? t0 - 4.0 * a.pad / dlen : t0;
    // (o − centre) + s·d rather than (o + s·d) − centre: the first difference is exact or nearly
    // so when the origin is near the scene (Sterbenz), so the float origin is accurate to the
    // scene's size even when the scene sits far from the world origin. Its rounding is about
    // u·(|o − centre| + |s·d|): for an origin far from a small scene that exceeds the exact
    // BVH's box padding, and the start point is then formed in double-double instead (TwoSum
    // and TwoProduct are exact, their sum is off by a few u² of the terms: Ogita, Rump & Oishi
    // 2005), which keeps it within the padding out to ~1e15 scene sizes.
    const double far = length(ray.origin - base) + std::abs(c.shift) * dlen;
    Vec3d org;
    if (8.0 * kDoubleUnitRoundoff * far <= 0.25 * a.pad) {
        org = (ray.origin - base) + ray.direction * c.shift;
        c.origin_err = 8.0 * kDoubleUnitRoundoff * far;
    } else {
        for (std::size_t k = 0; k < 3; ++k) {
            const dd::DD p = dd::add(dd::two_sum(ray.origin[k], -base[k]),
                                     dd::two_prod(ray.direction[k], c.shift));
            org[k] = p.hi + p.lo;
        }
        // The double-double residual, then the rounding of the (near-scene) point to double.
        c.origin_err = 8.0 * kDoubleUnitRoundoff * kDoubleUnitRoundoff * far +
                       2.0 * kDoubleUnitRoundoff * length(org);
        // Far, unless `far` only overflowed (coordinates past ~1e154 in a scene as large).
        c.far = 8.0 * kDoubleUnitRoundoff *
                    (scaled_length(ray.origin - base) + std::abs(c.shift) * dlen) >
                0.25 * a.pad;
    }
    const Vec3d dir = ray.direction * (1.0 / dlen);  // rounded to float next: one more u
    if (!(max_abs(org) <= 4.0 * a.float_scale) || !is_finite(org) || !(c.len > 0.0) ||
        !(c.len < std::numeric_limits<double>::infinity()) || !std::isfinite(c.margin / c.len)) {
        // The slab test's t0 is widened by γ₃·|t0|, relative to the distance: from an origin
        // more than ~1e16 scene sizes away the start point lies that far outside the bounds,
        // where the float ray's rounding exceeds the boxes' padding (and past 1.8e18 in Embree's
        // frame Embree asserts and aborts the process: a helper's review, 2026-12-05). Such a
        // ray is not traced in float: an empty segment, and an origin_err that sends it to the
        // linear scan (unplaced()). So is a direction whose length in Embree's frame over- or
        // underflows (1e150 long against a scene 1e-200 across), where t1 − t0 made tfar NaN
        // and Embree asserted (a second review).
        leave_unplaced(c, f);
        return true;
    }
    org = org * a.unit;  // into Embree's frame (Impl::unit): inside the scaled bounds
    f.org_x = to_float(org.x);
    f.org_y = to_float(org.y);
    f.org_z = to_float(org.z);
    f.dir_x = static_cast<float>(dir.x);
    f.dir_y = static_cast<float>(dir.y);
    f.dir_z = static_cast<float>(dir.z);
    f.tnear = 0.0f;
    f.tfar = std::isinf(t1) ? std::numeric_limits<float>::infinity() : tfar_for(c, t1);
    if (std::isnan(f.tfar))  // never handed to Embree, which asserts on it
        leave_unplaced(c, f);
    return true;
}

MoveResult move_near_scene(const Impl& a, const Ray& ray, MovedRay& m) {
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
    const double radius = 0.5 * scaled_length(a.padded_bounds.diagonal());
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
                dd::add(dd::add(dd::two_sum(o[k], -a.center[k]), dd::two_prod(d[k], shift.hi)),
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
    dd::DD shift{dot(a.center - o, d) / d2, 0.0};
    Vec3d q = point(shift);
    // Converged when the step is below 2⁻²⁰ of the distance to the centre, or below what the
    // double-double point itself resolves (a few u² of |o| and |shift·d|).
    const auto resolution = [&] {
        return 16.0 * kDoubleUnitRoundoff * kDoubleUnitRoundoff *
               (max_abs(o) + max_abs(a.center) + dlen * std::abs(shift.hi));
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
        max_abs(o) + max_abs(a.center) + max_abs(d) * (std::abs(shift.hi) + std::abs(shift.lo));
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
    bool range_ok = true;
    const auto moved = [&](double t) {
        if (std::isinf(t))
            return t;
        const double tau = std::ldexp(t, m.exp);  // exact unless it leaves double's range
        range_ok = range_ok && std::isfinite(tau) && (tau != 0.0 || t == 0.0);
        const dd::DD r = dd::sub(dd::DD{tau, 0.0}, shift);
        return r.hi + r.lo;
    };
    m.ray.tmin = moved(ray.tmin);
    m.ray.tmax = moved(ray.tmax);
    if (!range_ok)
        return MoveResult::not_possible;
    m.line_err = line_err(q);
    if (!std::isfinite(m.line_err) || std::isnan(m.ray.tmin) || std::isnan(m.ray.tmax))
        return MoveResult::not_possible;
    return MoveResult::moved;
}

double MovedRay::tau_of(double t_moved) const {
    const dd::DD t = dd::add(shift, dd::DD{t_moved, 0.0});
    return t.hi + t.lo;
}

}  // namespace raycastd::engine::embree
