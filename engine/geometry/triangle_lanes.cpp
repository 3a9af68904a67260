#include "engine/geometry/triangle_lanes.h"

#include <cmath>
#include <cstddef>
#include <limits>

#include <immintrin.h>

#include "engine/geometry/target_clones.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine {

bool triangle_lanes_available() {
    static const bool available =
        cpu_vectors_allowed() && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    return available;
}

namespace {

// Four doubles, one a lane, and the double-double steps of engine/math/double_double.h on them,
// operation for operation (each helper is the one of the same name there).
using V = __m256d;
struct DD4 {
    V hi, lo;
};

[[gnu::target("avx2,fma"), gnu::always_inline]] inline V splat(double x) {
    return _mm256_set1_pd(x);
}
[[gnu::target("avx2,fma"), gnu::always_inline]] inline V vabs(V x) {
    return _mm256_andnot_pd(_mm256_set1_pd(-0.0), x);
}
/// The larger of two lanes' values; for the finite, non-negative values it is given here the
/// same value as std::max, whichever order.
[[gnu::target("avx2,fma"), gnu::always_inline]] inline V vmax(V a, V b) {
    return _mm256_max_pd(a, b);
}
/// b where `mask` is set, else a.
[[gnu::target("avx2,fma"), gnu::always_inline]] inline V select(V a, V b, V mask) {
    return _mm256_blendv_pd(a, b, mask);
}
[[gnu::target("avx2,fma"), gnu::always_inline]] inline V finite(V x) {
    return _mm256_cmp_pd(vabs(x), splat(std::numeric_limits<double>::max()), _CMP_LE_OQ);
}
[[gnu::target("avx2,fma"), gnu::always_inline]] inline DD4 two_sum(V a, V b) {
    const V s = a + b;
    const V bb = s - a;
    return {s, (a - (s - bb)) + (b - bb)};
}
[[gnu::target("avx2,fma"), gnu::always_inline]] inline DD4 fast_two_sum(V a, V b) {
    const V s = a + b;
    return {s, b - (s - a)};
}
[[gnu::target("avx2,fma"), gnu::always_inline]] inline DD4 two_prod(V a, V b) {
    const V p = a * b;
    return {p, _mm256_fmsub_pd(a, b, p)};  // std::fma(a, b, −p): the same single rounding
}
[[gnu::target("avx2,fma"), gnu::always_inline]] inline DD4 add(DD4 a, DD4 b) {
    const DD4 s = two_sum(a.hi, b.hi);
    return fast_two_sum(s.hi, s.lo + (a.lo + b.lo));
}
[[gnu::target("avx2,fma"), gnu::always_inline]] inline DD4 mul(DD4 a, V b) {
    const DD4 p = two_prod(a.hi, b);
    return fast_two_sum(p.hi, _mm256_fmadd_pd(a.lo, b, p.lo));
}
[[gnu::target("avx2,fma"), gnu::always_inline]] inline V div(DD4 n, DD4 d) {
    const V t = n.hi / d.hi;
    const DD4 p = two_prod(t, d.hi);
    const V r = ((n.hi - p.hi) - p.lo) + n.lo - t * d.lo;
    return t + r / d.hi;
}

/// One of a vector's three components by lane: X where `x` is set, else Y where `y`, else Z.
[[gnu::target("avx2,fma"), gnu::always_inline]] inline V pick(V X, V Y, V Z, V x, V y) {
    return select(select(Z, Y, y), X, x);
}

/// Four lanes of one field of four rays (lane k: rays[k]).
#define RAYCASTD_LANES_OF(field) \
    _mm256_set_pd(rays[3]->field, rays[2]->field, rays[1]->field, rays[0]->field)

/// What each lane came to (bit k of each mask: lane k).
struct Verdicts {
    unsigned undecided = 0, hit = 0, outside = 0;  // the rest: a miss
    alignas(32) double t[4], t_err[4], u[4], v[4], det[4];
};

/// woop() of triangle.cpp (require_inside, t from the plane crossing, not rescaled), its
/// statements in its order, on four lanes; lanes that leave its common path are undecided.
[[gnu::target("avx2,fma")]] void decide_lanes(const Triangle& tri, const Ray* const rays[4],
                                              const PlaneNormal& plane, bool degenerate,
                                              bool decision_only, Verdicts& out) {
    constexpr double kMax = std::numeric_limits<double>::max();
    const V ox = RAYCASTD_LANES_OF(origin.x), oy = RAYCASTD_LANES_OF(origin.y),
            oz = RAYCASTD_LANES_OF(origin.z);
    const V dx = RAYCASTD_LANES_OF(direction.x), dy = RAYCASTD_LANES_OF(direction.y),
            dz = RAYCASTD_LANES_OF(direction.z);
    const V tmin = RAYCASTD_LANES_OF(tmin), tmax = RAYCASTD_LANES_OF(tmax);

    // make_shear's frame in each lane: kz the dominant axis of d (max_abs_dimension: ties to the
    // lower index), kx and ky the next two, swapped where d runs down kz so that the winding (the
    // sign of U, V, W) is kept (Woop et al. §3). Each coordinate is then picked from the lane's
    // x, y and z; the corners relative to the origin are formed before the pick (the same
    // differences).
    const V adx = vabs(dx), ady = vabs(dy), adz = vabs(dz);
    const V kz0 =
        _mm256_and_pd(_mm256_cmp_pd(adx, ady, _CMP_GE_OQ), _mm256_cmp_pd(adx, adz, _CMP_GE_OQ));
    const V kz1 = _mm256_andnot_pd(kz0, _mm256_cmp_pd(ady, adz, _CMP_GE_OQ));
    const V kz2 =
        _mm256_andnot_pd(_mm256_or_pd(kz0, kz1), _mm256_castsi256_pd(_mm256_set1_epi64x(-1)));
    const V dkz = pick(dx, dy, dz, kz0, kz1);
    const V neg = _mm256_cmp_pd(dkz, _mm256_setzero_pd(), _CMP_LT_OQ);
    // kx: y, z, x for kz = x, y, z (z, x, y where swapped); ky the other way round.
    const V kx_x = _mm256_or_pd(_mm256_andnot_pd(neg, kz2), _mm256_and_pd(neg, kz1));
    const V kx_y = _mm256_or_pd(_mm256_andnot_pd(neg, kz0), _mm256_and_pd(neg, kz2));
    const V ky_x = _mm256_or_pd(_mm256_andnot_pd(neg, kz1), _mm256_and_pd(neg, kz2));
    const V ky_y = _mm256_or_pd(_mm256_andnot_pd(neg, kz2), _mm256_and_pd(neg, kz0));
    const V Ax = splat(tri.a.x) - ox, Ay = splat(tri.a.y) - oy, Az = splat(tri.a.z) - oz;
    const V Bx = splat(tri.b.x) - ox, By = splat(tri.b.y) - oy, Bz = splat(tri.b.z) - oz;
    const V Cx = splat(tri.c.x) - ox, Cy = splat(tri.c.y) - oy, Cz = splat(tri.c.z) - oz;
    const V Akx = pick(Ax, Ay, Az, kx_x, kx_y), Aky = pick(Ax, Ay, Az, ky_x, ky_y),
            Akz = pick(Ax, Ay, Az, kz0, kz1);
    const V Bkx = pick(Bx, By, Bz, kx_x, kx_y), Bky = pick(Bx, By, Bz, ky_x, ky_y),
            Bkz = pick(Bx, By, Bz, kz0, kz1);
    const V Ckx = pick(Cx, Cy, Cz, kx_x, kx_y), Cky = pick(Cx, Cy, Cz, ky_x, ky_y),
            Ckz = pick(Cx, Cy, Cz, kz0, kz1);
    const V dkx = pick(dx, dy, dz, kx_x, kx_y), dky = pick(dx, dy, dz, ky_x, ky_y);
    const V sx = dkx / dkz;
    const V sy = dky / dkz;
    const V sz = splat(1.0) / dkz;

    // The shear (Woop et al., eq. 2) and the 2-D edge functions.
    const V ax = Akx - sx * Akz, ay = Aky - sy * Akz;
    const V bx = Bkx - sx * Bkz, by = Bky - sy * Bkz;
    const V cx = Ckx - sx * Ckz, cy = Cky - sy * Ckz;
    const V u = cx * by - cy * bx;
    const V v = ax * cy - ay * cx;
    const V w = bx * ay - by * ax;

    // Ordinary scale, or woop_rescaled (undecided).
    const V m = (vabs(u) + vabs(v)) + vabs(w);
    const V dm = vabs(dkz);
    const V ordinary = _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(m, splat(0x1p-600), _CMP_GE_OQ),
                                                   _mm256_cmp_pd(m, splat(0x1p600), _CMP_LE_OQ)),
                                     _mm256_and_pd(_mm256_cmp_pd(dm, splat(0x1p-250), _CMP_GE_OQ),
                                                   _mm256_cmp_pd(dm, splat(0x1p250), _CMP_LE_OQ)));
    // Every edge function beyond its rounding bound, or settle_edge (undecided).
    const V ma = vmax(vabs(Akx), vmax(vabs(Aky), vabs(Akz)));
    const V mb = vmax(vabs(Bkx), vmax(vabs(Bky), vabs(Bkz)));
    const V mc = vmax(vabs(Ckx), vmax(vabs(Cky), vabs(Ckz)));
    const V k = splat(8.0 * gamma(16));
    const V clear = _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(vabs(u), k * (mc * mb), _CMP_GT_OQ),
                                                _mm256_cmp_pd(vabs(v), k * (ma * mc), _CMP_GT_OQ)),
                                  _mm256_cmp_pd(vabs(w), k * (mb * ma), _CMP_GT_OQ));
    const V zero = _mm256_setzero_pd();
    const V ones = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    V undecided = _mm256_andnot_pd(_mm256_and_pd(ordinary, clear), ones);

    // Mixed signs: a miss. det zero or not finite: a miss. A degenerate triangle: a miss.
    const V any_neg = _mm256_or_pd(
        _mm256_or_pd(_mm256_cmp_pd(u, zero, _CMP_LT_OQ), _mm256_cmp_pd(v, zero, _CMP_LT_OQ)),
        _mm256_cmp_pd(w, zero, _CMP_LT_OQ));
    const V any_pos = _mm256_or_pd(
        _mm256_or_pd(_mm256_cmp_pd(u, zero, _CMP_GT_OQ), _mm256_cmp_pd(v, zero, _CMP_GT_OQ)),
        _mm256_cmp_pd(w, zero, _CMP_GT_OQ));
    const V det = (u + v) + w;
    V miss = _mm256_or_pd(_mm256_and_pd(any_neg, any_pos),
                          _mm256_or_pd(_mm256_cmp_pd(det, zero, _CMP_EQ_OQ),
                                       _mm256_cmp_pd(vabs(det), splat(kMax), _CMP_NLE_UQ)));
    if (degenerate)
        miss = ones;
    miss = _mm256_andnot_pd(undecided, miss);

    // Woop's sheared t and its bound (woop's t_error, pbrt-v4 §6.8.4), as there.
    const V az = sz * Akz, bz = sz * Bkz, cz = sz * Ckz;
    const V inv_det = splat(1.0) / det;
    const V max_z = vmax(vabs(az), vmax(vabs(bz), vabs(cz)));
    const V max_x = vmax(vabs(ax), vmax(vabs(bx), vabs(cx)));
    const V max_y = vmax(vabs(ay), vmax(vabs(by), vabs(cy)));
    const V max_z_len = max_z * vmax(splat(1.0), dm);
    const V delta_z = splat(gamma(3)) * max_z;
    const V delta_x = splat(gamma(5)) * (max_x + max_z_len);
    const V delta_y = splat(gamma(5)) * (max_y + max_z_len);
    const V delta_e =
        splat(2.0) * (splat(gamma(2)) * max_x * max_y + delta_y * max_x + delta_x * max_y);
    const V max_e = vmax(vabs(u), vmax(vabs(v), vabs(w)));
    const V inv = vabs(inv_det);
    const V te = splat(3.0) * (splat(gamma(3)) * (max_e * inv) * max_z + (delta_e * inv) * max_z +
                               delta_z * (max_e * inv));
    const V ts = (u * az + v * bz + w * cz) * inv_det;
    const V shear_ok = _mm256_and_pd(_mm256_and_pd(finite(ts), finite(te)),
                                     _mm256_cmp_pd(te, splat(0x1p-1000), _CMP_GE_OQ));
    const V open = _mm256_andnot_pd(_mm256_or_pd(undecided, miss), ones);
    undecided = _mm256_or_pd(undecided, _mm256_andnot_pd(shear_ok, open));
    const V margin = splat(2.0) * te + splat(8.0 * kDoubleUnitRoundoff) * vabs(ts);
    const V early_out = _mm256_or_pd(_mm256_cmp_pd(ts + margin, tmin, _CMP_LT_OQ),
                                     _mm256_cmp_pd(ts - margin, tmax, _CMP_GT_OQ));
    V outside = _mm256_andnot_pd(_mm256_or_pd(undecided, miss), early_out);
    // decide_triangle (TFrom::settled): where the sheared t and its margin lie inside the range,
    // the hit with the sheared t and no plane crossing.
    V sheared_hit = zero;
    if (decision_only) {
        sheared_hit = _mm256_andnot_pd(_mm256_or_pd(_mm256_or_pd(undecided, miss), outside),
                                       _mm256_and_pd(_mm256_cmp_pd(ts - margin, tmin, _CMP_GE_OQ),
                                                     _mm256_cmp_pd(ts + margin, tmax, _CMP_LE_OQ)));
    }
    const V open2 = _mm256_andnot_pd(
        _mm256_or_pd(_mm256_or_pd(undecided, miss), _mm256_or_pd(outside, sheared_hit)), ones);
    _mm256_store_pd(out.t_err, te);
    _mm256_store_pd(out.u, v * inv_det);
    _mm256_store_pd(out.v, w * inv_det);
    _mm256_store_pd(out.det, det);
    if (_mm256_movemask_pd(open2) == 0) {  // no lane needs the plane crossing
        out.undecided = static_cast<unsigned>(_mm256_movemask_pd(undecided));
        out.outside = static_cast<unsigned>(_mm256_movemask_pd(outside));
        out.hit = static_cast<unsigned>(_mm256_movemask_pd(sheared_hit));
        _mm256_store_pd(out.t, ts);
        return;
    }

    // The plane crossing (triangle.cpp's plane_t, its plain-double normal's path): the anchor
    // vertex nearest the origin (max norm: max_abs(a − o) is ma), v − o exact, both dot products
    // double-double.
    const V sel_b = _mm256_cmp_pd(mb, ma, _CMP_LT_OQ);
    const V best = select(ma, mb, sel_b);
    const V sel_c = _mm256_cmp_pd(mc, best, _CMP_LT_OQ);
    const V vx = select(select(splat(tri.a.x), splat(tri.b.x), sel_b), splat(tri.c.x), sel_c);
    const V vy = select(select(splat(tri.a.y), splat(tri.b.y), sel_b), splat(tri.c.y), sel_c);
    const V vz = select(select(splat(tri.a.z), splat(tri.b.z), sel_b), splat(tri.c.z), sel_c);
    const DD4 vo0 = two_sum(vx, -ox);
    const DD4 vo1 = two_sum(vy, -oy);
    const DD4 vo2 = two_sum(vz, -oz);
    const V nx = splat(plane.n.x), ny = splat(plane.n.y), nz = splat(plane.n.z);
    const DD4 num = add(add(mul(vo0, nx), mul(vo1, ny)), mul(vo2, nz));
    const DD4 den = add(add(two_prod(nx, dx), two_prod(ny, dy)), two_prod(nz, dz));
    const V t = div(num, den);
    const V dnx = splat(plane.dn.x), dny = splat(plane.dn.y), dnz = splat(plane.dn.z);
    const V four_u = splat(4.0 * kDoubleUnitRoundoff);
    const V vp0 = vabs(vo0.hi - dx * t) + four_u * (vabs(vo0.hi) + vabs(dx * t));
    const V vp1 = vabs(vo1.hi - dy * t) + four_u * (vabs(vo1.hi) + vabs(dy * t));
    const V vp2 = vabs(vo2.hi - dz * t) + four_u * (vabs(vo2.hi) + vabs(dz * t));
    const V shift = dnx * vp0 + dny * vp1 + dnz * vp2;
    const V slack = vabs(den.hi) - (dnx * vabs(dx) + dny * vabs(dy) + dnz * vabs(dz));
    const V allowed = splat(kDoubleUnitRoundoff) * vabs(t) * slack;
    const V settled = _mm256_and_pd(
        _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(den.hi, zero, _CMP_NEQ_OQ),
                                    _mm256_cmp_pd(slack, zero, _CMP_GT_OQ)),
                      _mm256_and_pd(_mm256_cmp_pd(allowed, splat(0x1p-1000), _CMP_GT_OQ),
                                    _mm256_cmp_pd(vp0 + vp1 + vp2, splat(0x1p70), _CMP_LT_OQ))),
        _mm256_and_pd(_mm256_cmp_pd(splat(8.0) * shift, allowed, _CMP_LE_OQ), finite(t)));
    undecided = _mm256_or_pd(undecided, _mm256_andnot_pd(settled, open2));
    const V in_range =
        _mm256_and_pd(_mm256_cmp_pd(t, tmin, _CMP_GE_OQ), _mm256_cmp_pd(t, tmax, _CMP_LE_OQ));
    const V open3 = _mm256_andnot_pd(undecided, open2);
    outside = _mm256_or_pd(outside, _mm256_andnot_pd(in_range, open3));
    const V hit = _mm256_or_pd(_mm256_and_pd(in_range, open3), sheared_hit);

    out.undecided = static_cast<unsigned>(_mm256_movemask_pd(undecided));
    out.outside = static_cast<unsigned>(_mm256_movemask_pd(outside));
    out.hit = static_cast<unsigned>(_mm256_movemask_pd(hit));
    _mm256_store_pd(out.t, select(t, ts, sheared_hit));
}

#undef RAYCASTD_LANES_OF

}  // namespace

namespace {

unsigned triangle_lanes(const Triangle& tri, const Ray* const rays[], unsigned count,
                        bool want_normal, bool decision_only, std::optional<Hit> hits[],
                        LineCrossing outside[]) {
    const unsigned all = count >= 32 ? ~0u : (1u << count) - 1u;
    if (count == 0 || count > 4 || !triangle_lanes_available())
        return all;
    // Lanes past `count` repeat the first ray (their answers are not read).
    const Ray* lanes[4];
    for (unsigned k = 0; k < 4; ++k)
        lanes[k] = rays[k < count ? k : 0];
    // The triangle's own quantities, once for all lanes: woop's edge cross product (its
    // degeneracy test, and the hit's normal) and plane_t's scaled normal.
    const Vec3d n = edge_cross(tri);
    Verdicts verdicts;
    decide_lanes(tri, lanes, plane_normal(tri), n == Vec3d{0.0, 0.0, 0.0}, decision_only, verdicts);
    const Vec3d normal = want_normal && verdicts.hit != 0 ? normalize(n) : Vec3d{};
    for (unsigned k = 0; k < count; ++k) {
        const unsigned bit = 1u << k;
        if (verdicts.undecided & bit)
            continue;
        hits[k].reset();
        if (verdicts.outside & bit) {
            outside[k] = LineCrossing{verdicts.u[k], verdicts.v[k], true};
        } else if (verdicts.hit & bit) {
            // woop's hit_at, field by field.
            Hit& h = hits[k].emplace();
            h.t = verdicts.t[k];
            h.u = verdicts.u[k];
            h.v = verdicts.v[k];
            h.primitive = 0;
            // woop's on_edge (an edge function exactly 0) is never set here: a decided lane's
            // edge functions all cleared their rounding bounds, so none is 0.
            h.on_edge = false;
            h.front_face = verdicts.det[k] > 0.0;
            h.t_err = verdicts.t_err[k];
            if (want_normal)
                h.normal = normal;
        }
    }
    return verdicts.undecided & all;
}

}  // namespace

unsigned intersect_triangle_lanes(const Triangle& tri, const Ray* const rays[], unsigned count,
                                  bool want_normal, std::optional<Hit> hits[],
                                  LineCrossing outside[]) {
    return triangle_lanes(tri, rays, count, want_normal, false, hits, outside);
}

unsigned decide_triangle_lanes(const Triangle& tri, const Ray* const rays[], unsigned count,
                               std::optional<Hit> hits[], LineCrossing outside[]) {
    return triangle_lanes(tri, rays, count, false, true, hits, outside);
}

}  // namespace raycastd::engine
