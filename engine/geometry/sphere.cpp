#include "engine/geometry/sphere.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "engine/geometry/target_clones.h"
#include "engine/math/double_double.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine {

// Double-double helpers (engine/math/double_double.h) for the few steps that need them.
using namespace dd;

// Compiled twice, with and without hardware FMA, and chosen when the program loads (GCC's
// function multiversioning): without it std::fma is a library call, and the double-double steps
// cost twice as much.
namespace {

/// `out` with the two roots t0, t1 in ascending order.
SphereRoots with_roots(SphereRoots out, double t0, double t1) {
    out.count = 2;
    out.t[0] = std::min(t0, t1);
    out.t[1] = std::max(t0, t1);
    return out;
}

/// Directions whose largest component is below 2⁻⁵⁰⁰ are scaled by 2⁶⁰⁰ first: their d·d
/// would be subnormal (or zero), where rounding is absolute rather than relative, and neither
/// the bounds nor TwoProduct's exactness hold (a helper's review found |d| ≈ 3e-162, inside a
/// sphere of radius 1e100, taken for a miss). o + t'·(2⁶⁰⁰d) = o + (2⁶⁰⁰t')·d, and scaling by
/// a power of two is exact, so the roots are the unscaled ray's.
constexpr double kTinyDirection = 0x1p-500;
constexpr double kDirectionScale = 0x1p600;

bool tiny_direction(const Vec3d& d) {
    const double m = max_abs(d);
    return m > 0.0 && m < kTinyDirection;
}

/// Origins, centres and radii past 2⁵⁰⁰ are scaled by 2⁻⁶⁰⁰ first: r² and |f|² overflow past
/// ~1.3e154, where a ray from the origin inside a sphere of radius 1e155 was taken for a miss
/// (an adversarial review). Scaling the geometry by a power of two keeps the direction:
/// s·o + t'·d = s·(o + t·d) with t' = s·t, so the roots are scaled_back's, as for a tiny
/// direction. (A coordinate below 2⁻⁴²² then becomes subnormal and rounds: next to a length
/// of 2⁵⁰⁰, far below its ulp.)
constexpr double kHugeLength = 0x1p500;
constexpr double kLengthScale = 0x1p-600;

/// The largest of the lengths the kernel multiplies (origin, centre, radius).
double max_length(const Sphere& s, const Ray& ray) {
    return std::max({max_abs(ray.origin), max_abs(s.center), s.radius});
}

bool huge_lengths(const Sphere& s, const Ray& ray) {
    return max_length(s, ray) > kHugeLength;
}

/// The sphere, and the ray's origin, times k (a power of two): the roots are then k times the
/// unscaled ones, the direction being kept.
Sphere sphere_times(const Sphere& s, double k) {
    return {s.center * k, s.radius * k};
}
Ray origin_times(const Ray& ray, double k) {
    Ray r = ray;
    r.origin = ray.origin * k;
    return r;
}

Ray with_scaled_direction(const Ray& ray) {
    Ray r = ray;
    r.direction = ray.direction * kDirectionScale;
    return r;
}

/// A radius below 2⁻⁴⁰⁰ (r² subnormal; a false tangent hit once r² and |f × d|² both underflow
/// to 0, a helper's review) scales the lengths up by k first, as far as the largest stays below
/// 2⁵⁰⁰; a sphere smaller than 2⁻⁹⁰⁰ of its distance or of the origin's coordinates is missed
/// (below double's resolution there). The roots come back times 1/k.
bool tiny_radius(const Sphere& s) {
    return s.radius > 0.0 && s.radius < 0x1p-400;
}

/// Where lengths times the direction's length leave 2^±500 (|f × d|² and a·r² are products of
/// four: a sphere 1e80 across hit by a ray whose direction is 1e80 long was taken for a miss,
/// one 1e-80 across with a direction 1e-80 long got roots off by 1e-6), the direction is
/// brought to [1, 2) by a power of two: the roots scale by the same power, exactly.
/// The radius times the direction's length counts too, not only the largest length: with
/// lengths scaled down from past 2⁵⁰⁰ (huge_lengths), a radius 2¹⁶⁰ times below the origin's
/// distance and a direction 2⁻⁴⁰⁰ long gave a·r² = 2⁻¹⁴⁰⁰ and |f × d|² = 2⁻¹⁰⁸⁰, both 0 in
/// double, and a false tangent root at t = 0 for a line passing 2¹⁶⁰ radii from the centre
/// (a helper's review, 2026-12-05).
/// A direction already in [1, 2) is not scaled again (lengths are at most 2⁵⁰⁰ by then, after
/// huge_lengths, and a radius 2⁻⁴⁰⁰ or more, after tiny_radius): that would recurse for ever.
/// A direction longer than 2²⁵⁰ is brought to [1, 2) too, whatever the lengths: its a = d·d
/// overflows past 2⁵¹², and with small enough lengths the products stayed under 2⁵⁰⁰: a ray
/// 2⁵²⁰ long, 2⁻⁹⁸ from a sphere of radius 2⁻¹⁰⁰, missed it (a second review).
constexpr double kLongDirection = 0x1p250;

bool extreme_products(const Sphere& s, const Ray& ray) {
    const double dm = max_abs(ray.direction);
    const double p = max_length(s, ray) * dm;
    const double rd = s.radius * dm;
    return (p > 0x1p500 || (p < 0x1p-500 && p > 0.0) || (rd < 0x1p-500 && rd > 0.0) ||
            dm > kLongDirection) &&
           !(dm >= 1.0 && dm < 2.0);
}

/// The ray with its direction brought to [1, 2) (extreme_products), and the power of two applied,
/// which the roots are multiplied by.
Ray with_unit_direction(const Ray& ray, double& k) {
    k = power_to_unit(max_abs(ray.direction));
    Ray r = ray;
    r.direction = ray.direction * k;
    return r;
}

SphereRoots times(SphereRoots r, double k) {
    r.t[0] *= k;
    r.t[1] *= k;
    r.t_err *= k;
    return r;
}

SphereRoots scaled_back(SphereRoots r) {
    return times(r, kDirectionScale);
}

/// sphere_roots for a sphere and ray beyond the plain kernel's ranges, by the first rule of
/// those above that applies (each recursion leaves its quantity in range, so at most a few
/// levels); nullopt when none does.
std::optional<SphereRoots> sphere_roots_rescaled(const Sphere& s, const Ray& ray) {
    if (tiny_direction(ray.direction))
        return scaled_back(sphere_roots(s, with_scaled_direction(ray)));
    if (huge_lengths(s, ray))  // scaled_back's 2⁶⁰⁰ undoes kLengthScale's 2⁻⁶⁰⁰
        return scaled_back(
            sphere_roots(sphere_times(s, kLengthScale), origin_times(ray, kLengthScale)));
    if (tiny_radius(s)) {
        // r to 1, or less where the largest length would pass 2⁵⁰⁰ that way, as long as r stays
        // at 2⁻⁴⁰⁰ or more.
        const double L = max_length(s, ray);
        double k = power_to_unit(s.radius);
        if (!(L * k <= 0x1p500))
            k = std::ldexp(1.0, 499 - std::ilogb(L));
        // At most 2¹⁰⁰⁰: for a radius below 2⁻¹⁰²³ the power above is 2¹⁰²⁴ or more, which is
        // inf, and the scaled call recursed until the stack ran out (r = 2⁻¹⁰⁷⁴ with an origin
        // as small: a helper's review). From 2¹⁰⁰⁰ the radius is 2⁻⁷⁴ or more: not tiny.
        k = std::min(k, 0x1p1000);
        if (!(s.radius * k >= 0x1p-400)) {
            SphereRoots none;
            none.unresolved = true;
            return none;
        }
        return times(sphere_roots(sphere_times(s, k), origin_times(ray, k)), 1.0 / k);
    }
    if (extreme_products(s, ray)) {
        double k;
        const Ray r = with_unit_direction(ray, k);
        return times(sphere_roots(s, r), k);  // o + t'·(k·d): t = k·t'
    }
    return std::nullopt;
}

/// Past 2²⁶ radii from the centre the components of f × d are formed by cross_far. Below, the
/// double-double products' error, a few u² of |f|·|d|, is at most 2⁻⁷⁹ of r·|d|, the size of
/// f × d near tangency: far below any decision it takes.
constexpr double kFarRadii = 0x1p26;

/// f₁·d₂ − f₂·d₁ for f₁, f₂ in double-double (the exact f = o − c), to a few u² of the result
/// however far the origin. Formed by mul(), the product's low part rounds by u·|f.lo·d| ≈
/// u²·|f|·|d|, which relative to f × d near tangency, ~r·|d|, is u²·|f|/r: a line passing
/// 1.2e-7 of a radius outside a sphere 2e-6 across, from ~1e21 away (~1e27 radii), hit it. Here the
/// eight parts of the two products (each exact by TwoProduct) are summed by SumK with K = 3 (Ogita,
/// Rump & Oishi 2005, Algorithm 4.8: two passes of the error-free VecSum, then the sum of the
/// rest), whose error is within γ³₁₄ of the parts' magnitudes
/// (~2¹³·u³·|f|·|d|) plus a rounding of the result (kept here as double-double).
// Out of line (its callers' FMA clones then call libm's fma from it: only far rays come here),
// where cross_dd is always inlined: a cross_dd out of line made 12 calls to libm's fma from
// sphere_roots' FMA clone for every near ray (a helper measured +16% a hit).
[[gnu::noinline]] DD cross_far(const DD& f1, double d2, const DD& f2, double d1) {
    const DD a = two_prod(f1.hi, d2), b = two_prod(f1.lo, d2);
    const DD c = two_prod(f2.hi, -d1), e = two_prod(f2.lo, -d1);
    double p[8] = {a.hi, c.hi, a.lo, c.lo, b.hi, e.hi, b.lo, e.lo};
    for (int pass = 0; pass < 2; ++pass) {
        for (int i = 1; i < 8; ++i) {
            const DD t = two_sum(p[i], p[i - 1]);
            p[i] = t.hi;
            p[i - 1] = t.lo;
        }
    }
    double rest = 0.0;
    for (int i = 0; i < 7; ++i)
        rest += p[i];
    return two_sum(p[7], rest);
}

/// f × d in double-double for f = o − c given exactly: by mul() near the sphere, by cross_far
/// from kFarRadii on.
[[gnu::always_inline]] inline void cross_dd(const DD& fx, const DD& fy, const DD& fz,
                                            const Vec3d& d, double radius, DD& cx, DD& cy, DD& cz) {
    if (std::max({std::abs(fx.hi), std::abs(fy.hi), std::abs(fz.hi)}) > kFarRadii * radius) {
        cx = cross_far(fy, d.z, fz, d.y);
        cy = cross_far(fz, d.x, fx, d.z);
        cz = cross_far(fx, d.y, fy, d.x);
        return;
    }
    cx = add(mul(fy, d.z), neg(mul(fz, d.y)));
    cy = add(mul(fz, d.x), neg(mul(fx, d.z)));
    cz = add(mul(fx, d.y), neg(mul(fy, d.x)));
}

}  // namespace

RAYCASTD_FMA_CLONES SphereRoots sphere_roots(const Sphere& s, const Ray& ray) {
    {
        // One test for the ordinary case (a helper measured three separate ones at +20% of a
        // miss): lengths, radius, direction and their product in range.
        const double L = max_length(s, ray), D = max_abs(ray.direction), p = L * D;
        const double rd = s.radius * D;
        const bool ordinary = D >= kTinyDirection && D <= kLongDirection && L <= kHugeLength &&
                              !tiny_radius(s) && p <= 0x1p500 && (p >= 0x1p-500 || p == 0.0) &&
                              (rd >= 0x1p-500 || rd == 0.0);
        if (!ordinary) {
            if (const std::optional<SphereRoots> r = sphere_roots_rescaled(s, ray))
                return *r;
        }
    }
    SphereRoots out;
    const Vec3d& d = ray.direction;
    {
        // Most rays that reach a sphere miss it by far: decide those in plain double. The
        // discriminant a·r² − |f × d|² formed from the rounded f = o − c is within
        // 40u·|f|²|d|² + 8u·a·r² of the exact one (Higham 2002, Lemma 3.1 applied to the cross
        // product and the two dot products); 64u on both terms leaves room. Lemma 3.1 needs
        // relative rounding: a tiny direction has been scaled above (tiny_direction), r² below
        // 2⁻¹⁰⁰⁰ goes to the double-double path, and 2⁻⁹⁰⁰ covers products that underflow.
        const Vec3d f = ray.origin - s.center;
        const double a = dot(d, d);
        const double r2 = s.radius * s.radius;
        const Vec3d c = cross(f, d);
        const double ar2 = a * r2;
        const double bound = 64.0 * kDoubleUnitRoundoff * (dot(f, f) * a + ar2) + 0x1p-900;
        if (r2 >= 0x1p-1000 && ar2 - dot(c, c) < -bound)
            return out;
    }
    // f = o − c, exactly: a ray starting far from a small sphere loses nothing here.
    const DD fx = two_sum(ray.origin.x, -s.center.x);
    const DD fy = two_sum(ray.origin.y, -s.center.y);
    const DD fz = two_sum(ray.origin.z, -s.center.z);
    const DD a = add(add(two_prod(d.x, d.x), two_prod(d.y, d.y)), two_prod(d.z, d.z));
    const DD beta = add(add(mul(fx, d.x), mul(fy, d.y)), mul(fz, d.z));

    // Δ/4 = β² − a·γ = a·r² − |f × d|² (Lagrange's identity; the RTG 2019 form a·(r² − |l|²)
    // with |l| = |f × d|/√a): no difference of two huge squares, and in double-double the
    // cancellation near tangency costs nothing visible.
    DD cx, cy, cz;
    cross_dd(fx, fy, fz, d, s.radius, cx, cy, cz);
    const DD fxd2 = add(add(mul(cx, cx), mul(cy, cy)), mul(cz, cz));
    const DD r2 = two_prod(s.radius, s.radius);
    const DD disc = add(mul(a, r2), neg(fxd2));
    if (!(disc.hi >= 0.0))
        return out;  // also rejects NaN

    // Error bound: every step above is a few u² relative to |f|·|d| and the roots below are
    // within 2 ulps of the truth; γ₁₂ times the distance scale (|f| + r)/|d| bounds that with a
    // wide margin.
    const double scale =
        (std::sqrt(fx.hi * fx.hi + fy.hi * fy.hi + fz.hi * fz.hi) + s.radius) / std::sqrt(a.hi);
    out.t_err = gamma(12) * scale;

    // The roots t_c ∓ h around the closest approach t_c = −β/a, h = √(Δ/4)/a, each rounded
    // once from double-double. This is the form a student writes (the tutorial's 9 ∓ √3, printed
    // by the API as 7.267949192431123), and where the subtraction cannot cancel (h ≤ |t_c|/2)
    // it is within 2 ulps: |t| ≥ |t_c|/2 and |t| ≥ h, so the three roundings cost at most
    // ulp(t) + ½ulp(t) + ½ulp(t).
    const double tc = div(neg(beta), a);
    if (disc.hi == 0.0) {
        // Tangent: one root, at the closest approach. Reported once, deliberately.
        out.count = 1;
        out.t[0] = out.t[1] = tc;
        return out;
    }
    const DD root = sqrt_dd(disc);
    const double h = div(root, a);
    // One sign for β decides both roots below: the far one here and q below. Told from
    // tc = −β/a instead, a ray starting in the plane through the centre (β = 0, tc = ±0, the
    // rounded quotient's sign of zero not β's) had both roots +h: a ray from the centre of a
    // radius-2 sphere hit it at t = 2 twice, and never at −2 (found by a helper's review).
    const bool beta_negative = beta.hi < 0.0;
    // The root away from the origin, tc − sign(β)·h = q/a: never cancels.
    double t0 = beta_negative ? tc + h : tc - h;
    double t1;
    if (h <= 0.5 * std::abs(tc)) {
        t1 = beta_negative ? tc - h : tc + h;
    } else {
        // The origin is near the surface (or inside): the near root is γ/q with
        // q = −(β + sign(β)·√Δ) (Press et al., Numerical Recipes §5.6), a sum of two numbers of
        // one sign, and γ = f·f − r² in double-double, so a root of 1e-12 is still exact to an
        // ulp.
        const DD q = neg(add(beta, beta_negative ? neg(root) : root));
        const DD gamma_c = add(add(add(mul(fx, fx), mul(fy, fy)), mul(fz, fz)), neg(r2));
        t1 = div(gamma_c, q);  // q ≠ 0 here: |q| ≥ √disc > 0
    }
    return with_roots(out, t0, t1);
}

namespace {

/// The unit normal (p − c)/r at the root t of a ray from more than kNormalFarRadii away: p − c
/// is the closest approach l = (d × (f × d))/a plus or minus the half-chord h·d (h = √(a·r² −
/// |f × d|²)/a; RTG 2019 eq. 7.5's terms), in double-double with f × d by cross_dd, rather than
/// f + t·d: t is rounded by u·|f|/|d|, which moves the point along the ray by u·|f|, and from
/// ~1e16 radii away that is the whole sphere (the normal of a line hitting a sphere 2e-6 across
/// from 2^60 away came out (0, 0, 0), and front_face false). Which sign: t before the closest
/// approach −β/a is the near root, unless `side` says which (−1 near, +1 far): from that far
/// both roots of a near-tangent line round to one t. The direction is first brought to [1, 2)
/// and f and r to the radius' scale, by powers of two (exact; the normal does not change), as
/// sphere_roots_rescaled does for the roots: unscaled, the products left double's range for
/// lengths past ~2^550 or below ~2^-520 or directions ~2^±600, and the plain form answered
/// (a helper's review). The lengths' power is the radius' own, at most 2¹⁰⁰⁰ (a subnormal
/// radius' is inf) and at most what keeps f within 2⁵⁰⁰ (beyond 2⁵⁰⁰ radii the radius then
/// shrinks instead, to 2⁻⁴⁰⁰ or more wherever the roots find a hit), as sphere_roots_rescaled
/// chooses it for a tiny radius (a second review found zero normals for a radius below 2⁻¹⁰²³
/// and (0, 1, 0) from 2⁵⁰¹ radii on). Its error is a few u, plus cross_far's. nullopt on
/// degenerate input (then the plain form).
std::optional<Vec3d> normal_from_closest_approach(const Sphere& s, const Ray& ray, double t,
                                                  int side) {
    const double dmax = max_abs(ray.direction);
    if (!(s.radius > 0.0) || !std::isfinite(s.radius) || !(dmax > 0.0) || !std::isfinite(dmax))
        return std::nullopt;
    // f = o − c, exactly, at 2^ef: halved where o − c could overflow (an origin at -1e308 and a
    // centre at 1e308 gave a NaN normal, written as null, and front_face false: a helper's
    // review). Halving coordinates above 2^1000 loses no digit that matters at that scale.
    const int ef = std::max(max_abs(ray.origin), max_abs(s.center)) > 0x1p1000 ? -1 : 0;
    const auto diff = [ef](double o, double c) {
        return two_sum(std::ldexp(o, ef), -std::ldexp(c, ef));
    };
    const DD f[3] = {diff(ray.origin.x, s.center.x), diff(ray.origin.y, s.center.y),
                     diff(ray.origin.z, s.center.z)};
    const double fmax = std::max({std::abs(f[0].hi), std::abs(f[1].hi), std::abs(f[2].hi)});
    if (!std::isfinite(fmax))
        return std::nullopt;
    // Exponents, not powers: kr/kd could overflow where the true scaled t cannot.
    const int ed = -std::ilogb(dmax);
    int er = std::min(-std::ilogb(s.radius), 1000);
    if (fmax > 0.0)
        er = std::min(er, 499 - (std::ilogb(fmax) - ef));
    const Vec3d d = ray.direction * std::ldexp(1.0, ed);
    const double r = std::ldexp(s.radius, er);
    if (!(r > 0.0))
        return std::nullopt;
    // f held at 2^ef, brought to 2^er.
    const auto scaled = [&](const DD& x) {
        return DD{std::ldexp(x.hi, er - ef), std::ldexp(x.lo, er - ef)};
    };
    const DD fx = scaled(f[0]), fy = scaled(f[1]), fz = scaled(f[2]);
    DD cx, cy, cz;
    cross_dd(fx, fy, fz, d, r, cx, cy, cz);
    const DD a = add(add(two_prod(d.x, d.x), two_prod(d.y, d.y)), two_prod(d.z, d.z));
    const DD beta = add(add(mul(fx, d.x), mul(fy, d.y)), mul(fz, d.z));
    // d × (f × d) = a·f − β·d = a·l.
    const Vec3d l{div(add(mul(cz, d.y), neg(mul(cy, d.z))), a),
                  div(add(mul(cx, d.z), neg(mul(cz, d.x))), a),
                  div(add(mul(cy, d.x), neg(mul(cx, d.y))), a)};
    const DD disc =
        add(mul(a, two_prod(r, r)), neg(add(add(mul(cx, cx), mul(cy, cy)), mul(cz, cz))));
    const double h = disc.hi > 0.0 ? div(sqrt_dd(disc), a) : 0.0;
    // t on the scaled ray: k_r·(f + t·d) = f′ + (t·k_r/k_d)·d′.
    const bool near = side != 0 ? side < 0 : std::ldexp(t, er - ed) <= div(neg(beta), a);
    const Vec3d pc = near ? l - d * h : l + d * h;
    if (!is_finite(pc) || !(std::abs(length(pc) - r) <= 0x1p-10 * r))
        return std::nullopt;
    return pc / r;
}

/// sphere_normal at the root on `side` (−1 the near one, +1 the far one, 0 unknown: told by t).
void sphere_normal_at(const Sphere& s, const Ray& ray, double t, int side, Hit& hit) {
    // (p − c)/r is exact for the points a reader checks by hand (the tutorial's (0, −1, −√3)/2
    // gives −0.5, not −0.5000000000000001); when rounding in p leaves it visibly off unit
    // length (far from the origin), normalise instead.
    const Vec3d pc = ray.origin - s.center + ray.direction * t;
    Vec3d n = pc / s.radius;
    // The distance scaled down, not the radius up: 2²⁰·r overflows for a radius past 1.7e302,
    // and an o − c that overflowed then compared inf <= inf and took the plain form's NaN.
    if (!(max_abs(ray.origin - s.center) / kNormalFarRadii <= s.radius)) {
        if (const std::optional<Vec3d> far = normal_from_closest_approach(s, ray, t, side))
            n = *far;
    }
    const double len2 = dot(n, n);
    if (std::abs(len2 - 1.0) > 8.0 * kDoubleUnitRoundoff)
        n = normalize(pc);
    hit.normal = n;
    hit.front_face = dot(ray.direction, hit.normal) < 0.0;
}

}  // namespace

int root_side(const SphereRoots& r, int i) {
    return r.count < 2 ? 0 : (i == 0 ? -1 : 1);
}

void sphere_normal(const Sphere& s, const Ray& ray, double t, Hit& hit) {
    sphere_normal_at(s, ray, t, 0, hit);
}

void sphere_normal(const Sphere& s, const Ray& ray, double t, int side, Hit& hit) {
    sphere_normal_at(s, ray, t, side, hit);
}

double sphere_closest_approach(const Sphere& s, const Ray& ray) {
    const Vec3d f = ray.origin - s.center;
    return -dot(f, ray.direction) / dot(ray.direction, ray.direction);
}

std::optional<Hit> intersect_sphere(const Sphere& s, const Ray& ray, bool want_normal) {
    return first_hit_of_roots(s, ray, sphere_roots(s, ray), want_normal);
}

std::optional<Hit> first_hit_of_roots(const Sphere& s, const Ray& ray, const SphereRoots& r,
                                      bool want_normal) {
    const int i = first_root_in_range(r, ray);
    if (i < 0)
        return std::nullopt;
    Hit hit;
    hit.t = r.t[i];
    hit.t_err = r.t_err;
    hit.primitive = 0;
    if (want_normal)
        sphere_normal_at(s, ray, hit.t, root_side(r, i), hit);
    return hit;
}

SphereRoots sphere_roots_fast(const Sphere& s, const Ray& ray) {
    if (tiny_direction(ray.direction))
        return scaled_back(sphere_roots_fast(s, with_scaled_direction(ray)));
    if (max_abs(ray.direction) > kLongDirection) {  // d·d would overflow past 2⁵¹²
        double k;
        const Ray r = with_unit_direction(ray, k);
        return times(sphere_roots_fast(s, r), k);
    }
    SphereRoots out;
    const Vec3d& d = ray.direction;
    const Vec3d f = ray.origin - s.center;
    const double a = dot(d, d);
    const double beta = dot(f, d);
    // l = f − (β/a)·d, the vector from the centre to the closest approach: r² − |l|² does not
    // subtract two huge squares for a far origin (RTG 2019, eq. 7.5).
    const Vec3d l = f - d * (beta / a);
    const double r2 = s.radius * s.radius;
    const double f2 = dot(f, f);
    // Squares of lengths (or of the direction) beyond 2^±900 are near overflow or have lost
    // digits to underflow (past ~1e154 from the centre |f|² overflows, and so does r² past a
    // radius of ~1e154, which a sphere 1e155 across had taken for a miss before this test came
    // first): the plain-double form is meaningless there, and the double-double kernel handles
    // them (scaling lengths and the direction first). A zero |f|² is fine: an origin at the
    // centre.
    if (!(r2 >= 0x1p-900 && r2 <= 0x1p900 && f2 <= 0x1p900 && a >= 0x1p-900 && a <= 0x1p900))
        return sphere_roots(s, ray);
    const double l2 = dot(l, l);
    const double disc = r2 - l2;  // Δ/(4a)
    if (!(disc >= 0.0))
        return out;
    // Error of disc: l carries ~u·|f| per component, so |l|² is off by ~4u·|f|·|l| + u·|l|²;
    // the roots move by δdisc/(2√disc) near tangency (√u behaviour), plus the rounding of the
    // distance scale elsewhere.
    const double f_len = std::sqrt(f2);
    const double len = std::sqrt(a);
    const double scale = (f_len + s.radius) / len;
    const double ddisc = 8.0 * kDoubleUnitRoundoff * (f_len * std::sqrt(l2) + l2 + r2);
    const double root = std::sqrt(disc);
    out.t_err = gamma(16) * scale + ddisc / (len * std::max(root, std::sqrt(ddisc)));
    const double h = std::sqrt(a) * root;  // √(Δ/4)
    if (disc == 0.0) {
        out.count = 1;
        out.t[0] = out.t[1] = -beta / a;
        return out;
    }
    // q = −(β + sign(β)·√(Δ/4)): one root is q/a, the other γ/q with γ = |f|² − r², formed as
    // (|f| − r)(|f| + r) so that an origin near the surface keeps its digits (Press et al.,
    // Numerical Recipes §5.6).
    const double q = -(beta + std::copysign(h, beta));
    double t0 = q / a;
    double t1 = q != 0.0 ? ((f_len - s.radius) * (f_len + s.radius)) / q : -t0;
    return with_roots(out, t0, t1);
}

namespace {

int hits_in_range(const Sphere& s, const Ray& ray, const SphereRoots& r, Hit out[2]) {
    int n = 0;
    for (int k = 0; k < r.count; ++k) {
        if (!(r.t[k] >= ray.tmin && r.t[k] <= ray.tmax && std::isfinite(r.t[k])))
            continue;  // an overflowed root is no hit (first_root_in_range)
        Hit& h = out[n++];
        h = Hit{};
        h.t = r.t[k];
        h.t_err = r.t_err;
        h.primitive = 0;
        sphere_normal_at(s, ray, h.t, root_side(r, k), h);
    }
    return n;
}

}  // namespace

int sphere_hits_fast(const Sphere& s, const Ray& ray, Hit out[2]) {
    return hits_in_range(s, ray, sphere_roots_fast(s, ray), out);
}

int sphere_hits(const Sphere& s, const Ray& ray, Hit out[2]) {
    return hits_in_range(s, ray, sphere_roots(s, ray), out);
}

}  // namespace raycastd::engine
