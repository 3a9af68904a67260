#include "engine/accel/embree/float_ray.h"

#include <limits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "engine/math/double_double.h"

namespace raycastd::engine::embree {

bool clip_to_bounds(const Impl& a, const Ray& ray, double& t0, double& t1) {
    return clip_to_bounds(a.padded_bounds, ray, t0, t1);
}

namespace {

/// (lo, hi) = (x, y) if x > y is false, else (y, x), without a branch. In clip_to_bounds that
/// comparison is the sign of a direction component, a coin toss for random directions, and the
/// mispredicted swap it replaced was most of that function's cost (perf of a random batch at
/// refined: clip_to_bounds 10% of it, 17% with the hit filter switched off, ~25 ns a ray). GCC
/// turns std::min and the ternary back into a compare and jump, hence SSE2's minsd and maxsd,
/// whose NaN rule (the second operand unless the comparison holds) gives the swap's values.
inline void ordered(double x, double y, double& lo, double& hi) {
#if defined(__SSE2__)
    lo = _mm_cvtsd_f64(_mm_min_sd(_mm_set_sd(y), _mm_set_sd(x)));  // y < x ? y : x
    hi = _mm_cvtsd_f64(_mm_max_sd(_mm_set_sd(x), _mm_set_sd(y)));  // x > y ? x : y
#else
    const bool swap = x > y;
    lo = swap ? y : x;
    hi = swap ? x : y;
#endif
}

}  // namespace

bool clip_to_bounds(const Bounds3& bounds, const Ray& ray, double& t0, double& t1) {
    // Slab test in double (Kay & Kajiya 1986) against the padded bounds. In locals: t0 and t1
    // could alias the ray, which kept them in memory through the loop.
    double lo_t = ray.tmin, hi_t = ray.tmax;
    bool meets = true;
    for (std::size_t k = 0; k < 3; ++k) {
        const double o = ray.origin[k], d = ray.direction[k];
        const double lo = bounds.lo[k], hi = bounds.hi[k];
        if (d == 0.0) {
            if (o < lo || o > hi) {
                meets = false;
                break;
            }
            continue;
        }
        // One reciprocal rather than two divisions (the slab test was 7% of a refined batch,
        // perf): (lo − o)·(1/d) rounds three times, which the widening below covers.
        const double inv = 1.0 / d;
        const double tl = (lo - o) * inv, th = (hi - o) * inv;
        double ta, tb;
        ordered(tl, th, ta, tb);
        // Widen by a few ulps: the subtraction, reciprocal and product round (γ₃), and a hit at
        // the slab's edge must survive.
        lo_t = std::max(lo_t, ta - gamma(3) * std::abs(ta));
        hi_t = std::min(hi_t, tb + gamma(3) * std::abs(tb));
    }
    t0 = lo_t;
    t1 = hi_t;
    return meets && lo_t <= hi_t;
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
    c.margin = float_margin(a);
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
    return move_near_ball(a.center, 0.5 * scaled_length(a.padded_bounds.diagonal()), ray, m);
}

}  // namespace raycastd::engine::embree
