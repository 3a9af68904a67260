#include "engine/geometry/triangle.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "engine/geometry/target_clones.h"
#include "engine/geometry/woop_edges.h"
#include "engine/math/double_double.h"
#include "engine/math/exact_sign.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine {

// Double-double helpers (engine/math/double_double.h) for the few steps that need them.
using namespace dd;

namespace {

/// The vertex nearest the origin (max norm). Anchoring the plane there makes the numerator's
/// rounding scale with that distance, and an origin exactly on a vertex gets t = 0 exactly.
const Vec3d& anchor_vertex(const Triangle& tri, const Vec3d& origin) {
    const Vec3d* anchor = &tri.a;
    double best = max_abs(tri.a - origin);
    for (const Vec3d* v : {&tri.b, &tri.c}) {
        const double dist = max_abs(*v - origin);
        if (dist < best) {
            best = dist;
            anchor = v;
        }
    }
    return *anchor;
}

/// plane_normal's body, kept in line in plane_t (hot in refined and exact) as it was before the
/// four-lane kernels came to share it; they call plane_normal once per triangle.
[[gnu::always_inline]] inline PlaneNormal plane_normal_in_line(const Triangle& tri) {
    // t is the same for any multiple of n: the edges are brought to unit scale (unit_scale),
    // so that n's products neither overflow nor underflow for a triangle far larger or
    // smaller than its distance (or than 1).
    PlaneNormal p;
    const Vec3d e1_raw = tri.b - tri.a, e2_raw = tri.c - tri.a;
    p.ke = unit_scale(std::max(max_abs(e1_raw), max_abs(e2_raw)));
    const Vec3d e1 = e1_raw * p.ke, e2 = e2_raw * p.ke;
    p.n = cross(e1, e2);
    p.dn = gamma(5) * cross_magnitudes(e1, e2);
    return p;
}

}  // namespace

PlaneNormal plane_normal(const Triangle& tri) {
    return plane_normal_in_line(tri);
}

namespace {

/// Where the ray's line crosses the triangle's plane: t = n·(v − o) / n·d with v the anchor
/// vertex and n = (b − a)×(c − a), v − o exact (TwoSum) and both dot products double-double, so
/// that t is rounded once. A grazing ray, a sliver or a far origin, whose Woop t loses digits in
/// the shear, still gets t to about an ulp. NaN when n·d is zero to double-double precision (the
/// ray runs in or parallel to the plane).
///
/// n itself is first taken in plain double: a normal off by δn moves the crossing by
/// δn·(v − p) / n·d (p the crossing), which for the usual triangle, ray and distance is far
/// below an ulp of t. Where that bound is not (slivers, grazing rays, a triangle large next to
/// its distance), n is formed in double-double from exact edges.
///
/// Compiled twice, with and without hardware FMA, and chosen when the program loads (GCC's
/// function multiversioning): without it std::fma is a library call and this costs twice as much.
RAYCASTD_FMA_CLONES double plane_t(const Triangle& tri, const Ray& ray) {
    const Vec3d& d = ray.direction;
    const Vec3d& v = anchor_vertex(tri, ray.origin);
    const DD vo[3] = {two_sum(v.x, -ray.origin.x), two_sum(v.y, -ray.origin.y),
                      two_sum(v.z, -ray.origin.z)};
    const PlaneNormal pn = plane_normal_in_line(tri);
    const double ke = pn.ke;
    {
        const Vec3d& n = pn.n;
        const DD num = add(add(mul(vo[0], n.x), mul(vo[1], n.y)), mul(vo[2], n.z));
        const DD den = add(add(two_prod(n.x, d.x), two_prod(n.y, d.y)), two_prod(n.z, d.z));
        if (den.hi != 0.0) {
            const double t = div(num, den);
            // The normal's error, component by component (cross_magnitudes): a
            // coordinate-aligned triangle (a floor) has δn only along its normal, where v − p
            // has no component.
            const Vec3d& dn = pn.dn;
            // |v − p| from the computed crossing p = o + t·d, with 4u of its terms for the
            // rounding of vo's low part, the product and the difference. The true crossing is
            // |Δt|·|d| further, so |Δt| ≤ δn·|v − p| / (|n·d| − δn·|d|). Accept when that is
            // below u·|t|/8, an eighth of an ulp of t at most (u·|t| is less than one): with the
            // division's rounding t is then within 5/8 of an ulp of the true crossing.
            // Underflow: a product of the normal that underflows is off by up to 2⁻¹⁰⁷⁴ more,
            // which moves t by at most 2⁻¹⁰⁷⁴·Σ|v − p|ᵢ / slack: below a sixteenth of the
            // allowance while that allowance is above 2⁻¹⁰⁰⁰ and Σ|v − p|ᵢ below 2⁷⁰, which
            // is asked too. (The bound's own terms are no subnormals in a scene of ordinary
            // size: those would cost a microcode assist each, 3× the whole render's time.)
            auto vp = [&](std::size_t i) {
                const double dt = std::abs(d[i] * t), v_o = std::abs(vo[i].hi);
                return std::abs(vo[i].hi - d[i] * t) + 4.0 * kDoubleUnitRoundoff * (v_o + dt);
            };
            const Vec3d vps{vp(0), vp(1), vp(2)};
            const double shift = dot(dn, vps);
            const double slack = std::abs(den.hi) - (dn.x * std::abs(d.x) + dn.y * std::abs(d.y) +
                                                     dn.z * std::abs(d.z));
            const double allowed = kDoubleUnitRoundoff * std::abs(t) * slack;
            if (slack > 0.0 && allowed > 0x1p-1000 && vps.x + vps.y + vps.z < 0x1p70 &&
                8.0 * shift <= allowed)
                return t;
        }
    }
    const auto scaled = [ke](DD x) { return DD{x.hi * ke, x.lo * ke}; };  // exact: a power of 2
    const DD e1[3] = {scaled(two_sum(tri.b.x, -tri.a.x)), scaled(two_sum(tri.b.y, -tri.a.y)),
                      scaled(two_sum(tri.b.z, -tri.a.z))};
    const DD e2[3] = {scaled(two_sum(tri.c.x, -tri.a.x)), scaled(two_sum(tri.c.y, -tri.a.y)),
                      scaled(two_sum(tri.c.z, -tri.a.z))};
    const DD n[3] = {sub(mul(e1[1], e2[2]), mul(e1[2], e2[1])),
                     sub(mul(e1[2], e2[0]), mul(e1[0], e2[2])),
                     sub(mul(e1[0], e2[1]), mul(e1[1], e2[0]))};
    const DD num = add(add(mul(n[0], vo[0]), mul(n[1], vo[1])), mul(n[2], vo[2]));
    const DD den = add(add(mul(n[0], d.x), mul(n[1], d.y)), mul(n[2], d.z));
    if (den.hi == 0.0)
        return std::numeric_limits<double>::quiet_NaN();
    return div(num, den);
}

}  // namespace

/// (b − a) × (c − a), its edges brought to unit scale (unit_scale) where the plain product
/// would overflow or lose its digits to underflow: its direction is all triangle_normal and
/// is_degenerate ask of it. (A triangle 1e155 across had a NaN normal, one 1e-170 across was
/// taken for degenerate.)
Vec3d edge_cross(const Triangle& tri) {
    const Vec3d e1 = tri.b - tri.a, e2 = tri.c - tri.a;
    const Vec3d n = cross(e1, e2);
    const double m = max_abs(n);
    if (m >= 0x1p-1000 && m <= std::numeric_limits<double>::max())
        return n;  // an ordinary triangle: as before, bit for bit
    const double k = unit_scale(std::max(max_abs(e1), max_abs(e2)));
    return k == 1.0 ? n : cross(e1 * k, e2 * k);
}

Vec3d triangle_normal(const Triangle& tri) {
    return normalize(edge_cross(tri));
}

bool is_degenerate(const Triangle& tri) {
    return edge_cross(tri) == Vec3d{0.0, 0.0, 0.0};
}

namespace {

/// Where woop() takes t from.
enum class TFrom {
    plane,  ///< the plane crossing in double-double (plane_t): about an ulp
    shear,  ///< Woop's own sheared z, interpolated (pbrt-v4 §6.8.4): within its t_err
    /// The sheared z where it and its t_err alone put the crossing inside [tmin, tmax], the
    /// plane crossing elsewhere: plane's decision with shear's t (decide_triangle).
    settled,
};

std::optional<Hit> woop(const Triangle& tri, const Ray& ray, bool want_normal, bool require_inside,
                        TFrom t_from = TFrom::plane, bool rescaled = false,
                        LineCrossing* outside = nullptr);

/// The power of two woop_rescaled scales lengths by: the one that brings the geometric mean of
/// the triangle's size E and the corners' distance from the origin L to 1 (the edge functions
/// of a hit are products of lengths of E's order, t_err multiplies them by L's). 1 where L/E
/// exceeds 2⁶⁰⁰ (a triangle 1e-150 across seen from 1e50 away: no single scale serves both;
/// unscaled its edge functions are still normal numbers, and beyond ~2¹⁰⁰⁰ its corners are no
/// better known than its size anyway). Scaling by L (the first version) took a small triangle
/// far away to underflow, by E (the second) overflowed t_err (two helpers' reviews).
double woop_scale(const Vec3d& A, const Vec3d& B, const Vec3d& C) {
    const double L = std::max({max_abs(A), max_abs(B), max_abs(C)});
    const double E = std::max(max_abs(B - A), max_abs(C - A));
    if (!(L > 0.0 && E > 0.0 && std::isfinite(L) && std::isfinite(E)) || L > 0x1p600 * E)
        return 1.0;
    // The geometric mean of E and L to 1: E·k ≥ 2⁻³⁰⁰ and L·k ≤ 2³⁰⁰, so that t_err's products
    // (up to L²/E in the scaled units) stay finite too.
    return std::ldexp(1.0, -((std::ilogb(E) + std::ilogb(L)) / 2));
}

/// woop() with the triangle and the ray's origin scaled by kl and its direction by kd (powers
/// of two): kl·o + t'·kd·d = kl·(o + t·d) with t' = t·kl/kd, so the range goes in scaled and t
/// and t_err come back scaled, exactly (unless the true t is itself out of double's range);
/// barycentrics and the side do not change. kl is woop_scale's for the corners relative to the
/// origin (A, B, C), kd brings the direction to unit size where it lies beyond 2^±250
/// (unit_scale); where both are 1 this is woop() again, unscaled, not asked to rescale.
std::optional<Hit> woop_rescaled(const Triangle& tri, const Ray& ray, bool want_normal,
                                 bool require_inside, TFrom t_from, const Vec3d& A, const Vec3d& B,
                                 const Vec3d& C, LineCrossing* outside) {
    const double kl = woop_scale(A, B, C), kd = unit_scale(max_abs(ray.direction));
    const Triangle scaled{tri.a * kl, tri.b * kl, tri.c * kl};
    Ray r;
    r.origin = ray.origin * kl;
    r.direction = ray.direction * kd;
    const int e = std::ilogb(kl) - std::ilogb(kd);  // kl/kd, which may itself overflow
    r.tmin = std::ldexp(ray.tmin, e);
    r.tmax = std::ldexp(ray.tmax, e);
    std::optional<Hit> h =
        woop(scaled, r, /*want_normal=*/false, require_inside, t_from, true, outside);
    if (h) {
        // One power of two, kd/kl: applied in two steps t·kd/kl could overflow where the
        // result fits (a helper's review).
        h->t = std::ldexp(h->t, -e);
        h->t_err = std::ldexp(h->t_err, -e);
        if (require_inside && !std::isfinite(h->t))
            return std::nullopt;  // t overflowed on the way back: no hit (woop's last check)
        // The triangle's own normal, not the scaled copy's: normalising a cross product past
        // 2⁵⁰⁰ divides by its largest component first, and the scaled copy's came out an ulp
        // away, so a triangle's normal had depended on the ray (SceneScan, which keeps each
        // triangle's normal, differed from the linear scan by that ulp).
        if (want_normal)
            h->normal = triangle_normal(tri);
    }
    return h;
}

/// px·qy − py·qx with the 64-bit significand of long double, where the products of two doubles
/// are far closer to exact (the paper's fallback, one precision up).
double edge_function_ld(double px, double qy, double py, double qx) {
    using LD = long double;
    return static_cast<double>(LD(px) * LD(qy) - LD(py) * LD(qx));
}

/// An edge function e = px·qy − py·qx of the sheared corners p, q (of the triangle's corners
/// `p3`, `q3`) within its rounding bound (woop): mag = |p|ₓ|q|_y + |p|_y|q|ₓ with each sheared
/// coordinate's magnitude taken before its rounding (|X_kx| + |s_x·X_kz|); the sheared
/// coordinates err by γ₅ of those (the corner minus the origin, the shear's quotient, product
/// and difference: Higham 2002, Lemma 3.1), so e errs from ((p3 − o) × (q3 − o))·d / d_kz,
/// whose sign it has by construction (Woop et al. §3), by less than γ₁₃·mag; woop tests
/// γ₁₆·mag. Beyond that its sign is certain; within it the sign is the triple product's,
/// computed exactly (triple_product_sign), and e is replaced by 0 where that is 0, or by the
/// least normal double of that sign where its own sign differed (it is then within rounding of
/// 0 anyway, and the barycentrics built from it stay in [0, 1]). Before 2026-12-06 only an e of
/// exactly 0 was recomputed, in long double: the differential fuzzer (seed 1242742) found a line
/// through an icosahedron passing 1e-16 (relative) beside an edge whose two edge functions rounded
/// to 0, and long double gave the edge to the neighbour, 12 ulps of t away. Where the exact product
/// cannot be formed (a product near underflow or overflow) the long double value decides, as
/// before.
double settle_edge(double e, const Vec3d& p3, const Vec3d& q3, const Ray& ray, double px, double qy,
                   double py, double qx) {
    bool exact = false;
    const int sign = triple_product_sign(p3, q3, ray.origin, ray.direction, exact);
    if (!exact)
        return edge_function_ld(px, qy, py, qx);
    if (sign == 0)
        return 0.0;
    if ((e > 0.0) == (sign > 0) && e != 0.0)
        return e;
    return sign > 0 ? std::numeric_limits<double>::min() : -std::numeric_limits<double>::min();
}

/// Woop et al.'s test; with `require_inside = false` the edge-function signs are not checked
/// and neither is [tmin, tmax] (the plane crossing of a hit decided elsewhere). `rescaled`:
/// called by woop_rescaled, which is not asked again.
std::optional<Hit> woop(const Triangle& tri, const Ray& ray, bool want_normal, bool require_inside,
                        TFrom t_from, bool rescaled, LineCrossing* outside) {
    const Vec3d A = tri.a - ray.origin;
    const Vec3d B = tri.b - ray.origin;
    const Vec3d C = tri.c - ray.origin;
    const ShearFrame s = make_shear(ray.direction);

    // Shear the vertices so the ray runs along +z (Woop et al., eq. 2), and the scaled
    // barycentrics: 2-D edge functions of the sheared triangle at the origin (woop_edges.h,
    // whose woop_misses forms the same bits once a ray's frame is known).
    const ShearedEdges e = sheared_edges(A, B, C, s);
    const double ax = e.ax, ay = e.ay, bx = e.bx, by = e.by, cx = e.cx, cy = e.cy;
    double u = e.u, v = e.v, w = e.w;
    if (!rescaled) {
        // The edge functions are products of two lengths, the sheared t and t_err multiply
        // them by a third, and t_err's bound mixes lengths with the sheared z (lengths over the
        // direction's): beyond 2^±600 for the first, or a direction beyond 2^±250, those have
        // overflowed or lost their digits to underflow (a triangle 1e-160 across was missed,
        // one 1e155 across too; one 1e-110 across hit at t = 0 by the sheared t; a direction
        // 1e-100 long had t_err 1e85 times t). Such a triangle and ray are brought to unit
        // scale (woop_scale, unit_scale). Ordinary ones pay four comparisons.
        // (edges_in_scale: the sum of the edge functions' magnitudes and |d_kz| = max_abs(d).)
        if (!edges_in_scale(e, std::abs(ray.direction[s.kz]))) {
            return woop_rescaled(tri, ray, want_normal, require_inside, t_from, A, B, C, outside);
        }
    }
    if (require_inside) {
        // Each edge function's sign is certain where it exceeds its rounding bound; the rest
        // are decided exactly (settle_edge). Two triangles sharing an edge compute the same
        // value (negated) and the same bound from the same corners, so they take the same
        // path and stay watertight.
        // |X_kx| + |s_x·X_kz| ≤ 2·max|X| (|s_x|, |s_y| ≤ 1: kz is the dominant axis), so each
        // bound is γ₁₆·8 times the product of its two corners' largest coordinates, formed as
        // (m_p·m_q) so that both triangles of an edge round it alike.
        const double ma = max_abs(A), mb = max_abs(B), mc = max_abs(C);
        if (!edge_sign_certain(u, mc, mb))
            u = settle_edge(u, tri.c, tri.b, ray, cx, by, cy, bx);
        if (!edge_sign_certain(v, ma, mc))
            v = settle_edge(v, tri.a, tri.c, ray, ax, cy, ay, cx);
        if (!edge_sign_certain(w, mb, ma))
            w = settle_edge(w, tri.b, tri.a, ray, bx, ay, by, ax);
    } else if (u == 0.0 || v == 0.0 || w == 0.0) {
        // Not deciding (the plane crossing of a hit decided elsewhere): the value in long
        // double is enough for the barycentrics.
        u = edge_function_ld(cx, by, cy, bx);
        v = edge_function_ld(ax, cy, ay, cx);
        w = edge_function_ld(bx, ay, by, ax);
    }
    if (require_inside && (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return std::nullopt;
    }
    const double det = u + v + w;
    // det == 0: the ray lies in the triangle's plane or the triangle is degenerate (as seen
    // along the ray); both miss by contract.
    if (det == 0.0 || !std::isfinite(det))
        return std::nullopt;

    // The edge cross product is_degenerate() tests, kept for the hit's normal
    // (triangle_normal's, bit for bit).
    const Vec3d n = edge_cross(tri);
    if (n == Vec3d{0.0, 0.0, 0.0})
        return std::nullopt;
    // The inside/outside decision above is Woop's (watertight); t is the plane crossing in
    // double-double, which Woop's sheared t (rounded in the shear, and ill-conditioned for a
    // grazing ray) agrees with to its t_err.
    const double az = s.sz * A[s.kz], bz = s.sz * B[s.kz], cz = s.sz * C[s.kz];
    const double inv_det = 1.0 / det;

    // Conservative bound on |t_shear − t_exact| (pbrt-v4 §6.8.4, "Error bounds for t"); also
    // reported with the plane crossing, which is far closer. The sheared x and y err by γ₅ of
    // |X_kx| + |s_x·X_kz|, a length, where pbrt's δx takes the sheared z, X_kz/d_kz, which is
    // that length only for |d_kz| ≤ 1 (above it, smaller): for a longer direction the bound is
    // formed from |X_kz| itself. Until 2026-12-06 it was not, and t_err fell short by up to the
    // direction's length (a grazing ray along a direction 1,024 long: |t_shear − t| was 117
    // t_err; a helper's review, when the range began to be settled by this bound, below).
    auto t_error = [&] {
        const double max_z = max_abs(Vec3d{az, bz, cz});
        const double max_x = max_abs(Vec3d{ax, bx, cx});
        const double max_y = max_abs(Vec3d{ay, by, cy});
        const double max_z_len = max_z * std::max(1.0, std::abs(ray.direction[s.kz]));
        const double delta_z = gamma(3) * max_z;
        const double delta_x = gamma(5) * (max_x + max_z_len);
        const double delta_y = gamma(5) * (max_y + max_z_len);
        const double delta_e = 2.0 * (gamma(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
        const double max_e = max_abs(Vec3d{u, v, w});
        // Divided by det before the lengths multiply: max_e·max_z is a product of three
        // lengths, which underflowed to t_err = 0 for a triangle 1e-150 across.
        const double inv = std::abs(inv_det);
        return 3.0 * (gamma(3) * (max_e * inv) * max_z + (delta_e * inv) * max_z +
                      delta_z * (max_e * inv));
    };

    // Woop's own t: the sheared z interpolated by the edge functions.
    auto sheared_t = [&] { return (u * az + v * bz + w * cz) * inv_det; };
    // The hit at t, t_err (finite), with the barycentrics and side from the edge functions.
    auto hit_at = [&](double at, double err) {
        Hit hit;
        hit.t = at;
        hit.u = v * inv_det;
        hit.v = w * inv_det;
        hit.primitive = 0;
        hit.on_edge = (u == 0.0 || v == 0.0 || w == 0.0);
        // The sign of det is the winding of the triangle as seen along the ray (the kx/ky swap
        // of make_shear keeps it meaningful): det > 0 means the ray meets (b−a)×(c−a) head on.
        // Taking it from det rather than from the normal keeps it consistent with the inside
        // test.
        hit.front_face = det > 0.0;
        hit.t_err = err;
        if (want_normal)
            hit.normal = normalize(n);
        return hit;
    };
    // The line crosses the triangle (require_inside), but outside [tmin, tmax]: noted for the
    // caller, the barycentrics as a hit's.
    auto outside_range = [&]() -> std::optional<Hit> {
        if (outside)
            *outside = LineCrossing{v * inv_det, w * inv_det, true};
        return std::nullopt;
    };

    double t, t_err;
    double shear_err = -1.0;  // t_error(), where the block below has computed it
    if (t_from != TFrom::shear && require_inside) {
        // Where the sheared t and its bound settle the range, the plane crossing's decision is
        // known without it: plane_t is within an ulp or two of the exact crossing (above; or,
        // where its numerator cancels, within ~u² of |v − o|/|n·d|, far below t_err), the
        // sheared t within t_err of it, so the two differ by less than t_err + 4u·|t|, and
        // twice that is margin. Outside the range: no hit either way (a spawned ray's own
        // triangle, behind its origin, is the usual one; plane_t had been a quarter of a
        // refined render of the Duck, most of it for those). Inside it, for a caller that needs
        // no more than the decision (TFrom::settled): the hit, with the sheared t.
        const double ts = sheared_t();
        const double te = shear_err = t_error();
        // A bound below 2⁻¹⁰⁰⁰ (a triangle ~1e-320 off the origin's plane) is itself rounded:
        // the plane crossing decides there.
        if (std::isfinite(ts) && std::isfinite(te) && te >= 0x1p-1000) {
            const double margin = 2.0 * te + 8.0 * kDoubleUnitRoundoff * std::abs(ts);
            if (ts + margin < ray.tmin || ts - margin > ray.tmax)
                return outside_range();
            if (t_from == TFrom::settled && ts - margin >= ray.tmin && ts + margin <= ray.tmax)
                return hit_at(ts, te);
        }
    }
    if (t_from != TFrom::shear) {
        t = plane_t(tri, ray);
        if (std::isnan(t))
            return std::nullopt;  // in the plane to double-double precision
    } else {
        t = sheared_t();
    }
    // An inf t here (or NaN from inf − inf in the sheared sum) can be an intermediate's overflow
    // alone: u·az passes 1.8e308 for a triangle 1e80 across seen 1e160 away along a unit
    // direction, whose t is 1e160. The rescaled retry finds that t; one that truly overflows
    // comes back inf from it and is no hit (below). Before the range test, which an inf t fails
    // whenever tmax is finite (a helper's review).
    if (!rescaled && !std::isfinite(t))
        return woop_rescaled(tri, ray, want_normal, require_inside, t_from, A, B, C, outside);
    if (t_from != TFrom::shear) {
        if (require_inside && !(t >= ray.tmin && t <= ray.tmax))
            return outside_range();
        t_err = shear_err >= 0.0 ? shear_err : t_error();
    } else {
        t_err = t_error();
        // Only a hit certainly at or after tmin (pbrt-v4's t > δt): a ray spawned just off
        // this very triangle (shade/spawn.h) crosses its plane a hair behind its origin, which
        // the sheared t, off by up to t_err, could put in front.
        if (require_inside && !(t - t_err >= ray.tmin && t <= ray.tmax))
            return outside_range();
    }

    if (!std::isfinite(t_err) && !rescaled) {
        // t_err multiplies the sheared z (distance over direction length) by lengths: a
        // direction far shorter or longer than the distances (1e-300 against 1) overflowed it.
        return woop_rescaled(tri, ray, want_normal, require_inside, t_from, A, B, C, outside);
    }

    // A t that overflowed double is no hit, even with the default tmax = +inf: it cannot be
    // answered (JSON has no inf; the binary answer's t = +inf means a miss). Only the rescaled
    // pass gets here with one (the first hands it to the retry above).
    if (require_inside && !std::isfinite(t))
        return std::nullopt;
    return hit_at(t, t_err);
}

}  // namespace

std::optional<Hit> intersect_triangle(const Triangle& tri, const Ray& ray, bool want_normal,
                                      LineCrossing* outside) {
    return woop(tri, ray, want_normal, /*require_inside=*/true, TFrom::plane, false, outside);
}

std::optional<Hit> decide_triangle(const Triangle& tri, const Ray& ray, LineCrossing* outside) {
    return woop(tri, ray, /*want_normal=*/false, /*require_inside=*/true, TFrom::settled, false,
                outside);
}

std::optional<Hit> intersect_triangle_fast(const Triangle& tri, const Ray& ray, bool want_normal) {
    return woop(tri, ray, want_normal, /*require_inside=*/true, TFrom::shear);
}

std::optional<Hit> triangle_plane_hit(const Triangle& tri, const Ray& ray, bool want_normal) {
    return woop(tri, ray, want_normal, /*require_inside=*/false);
}

}  // namespace raycastd::engine
