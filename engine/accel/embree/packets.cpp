#include "engine/accel/embree/packets.h"

#include <algorithm>
#include <cstddef>
#include <limits>
#include <optional>

#include <immintrin.h>

#include "engine/geometry/target_clones.h"

namespace raycastd::engine::embree {

namespace {

/// A packet's context, flagged coherent or incoherent (a traversal hint: the answers are the
/// same either way).
RTCIntersectContext flagged_context(bool together) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags =
        together ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    return ctx;
}

}  // namespace

RTCIntersectContext packet_context(const Ray* rays, std::size_t m, double scene_scale) {
    const auto dir = [rays](std::size_t k) { return rays[k].direction; };
    const auto org = [rays](std::size_t k) { return rays[k].origin; };
    const double spread2 = 0.0025 * scene_scale * scene_scale;
    // Random rays: the second ray already fails the test, and the whole of it, which has no
    // early exit, had cost 50 instructions a ray of a refined batch of A's random rays
    // (callgrind). Asked first, it gives the same answer.
    if (m >= 2 && !coherent(2, dir, org, spread2))
        return flagged_context(false);
    return flagged_context(coherent(m, dir, org, spread2));
}

namespace {

/// fast_packet's and fast_any_packet's lanes, one ray at a time (processors without AVX): lane
/// k < m from rays[k]'s unclipped float ray, lanes past m repeating the last ray, switched off.
/// Returns false (with the lanes partly written) when some ray needs prepare_ray.
bool fill_fast_lanes_scalar(const Impl& a, const Ray* rays, std::size_t m, RTCRay16& r16,
                            int* valid) {
    for (std::size_t k = 0; k < kLanes; ++k) {
        FloatRay f;
        if (!unclipped_float_ray(a, rays[std::min(k, m - 1)], f))
            return false;
        fill_lane(r16, k, f, static_cast<unsigned>(k));
        valid[k] = k < m ? -1 : 0;
    }
    return true;
}

// A Ray is 8 doubles (origin, direction, tmin, tmax), which fill_fast_lanes_avx loads as two
// vectors of four.
static_assert(sizeof(Ray) == 8 * sizeof(double) && offsetof(Ray, direction) == 3 * sizeof(double) &&
                  offsetof(Ray, tmin) == 6 * sizeof(double) &&
                  offsetof(Ray, tmax) == 7 * sizeof(double),
              "Ray's layout as fill_fast_lanes_avx reads it");

/// to_float on four lanes: beyond float's range, ±∞. In bit operations on the comparisons'
/// masks rather than _mm256_blendv_pd: GCC 12 (with LTO) turned each blend of a constant into
/// four scalar branches, one per lane, 16 in fill_fast_lanes_avx, which callgrind counted at
/// about 900 instructions a call of 16 rays in a Duck render (objdump showed no vblendvpd left).
[[gnu::target("avx"), gnu::always_inline]] inline __m256d saturated_avx(__m256d t) {
    const __m256d above =
        _mm256_cmp_pd(t, _mm256_set1_pd(std::numeric_limits<float>::max()), _CMP_GT_OQ);
    const __m256d below =
        _mm256_cmp_pd(t, _mm256_set1_pd(-std::numeric_limits<float>::max()), _CMP_LT_OQ);
    const __m256d inf = _mm256_set1_pd(std::numeric_limits<double>::infinity());
    const __m256d sign = _mm256_set1_pd(-0.0);
    // t where neither holds; +∞ above; −∞ (+∞ with the sign bit) below.
    const __m256d beyond = _mm256_or_pd(above, below);
    return _mm256_or_pd(_mm256_andnot_pd(beyond, t),
                        _mm256_or_pd(_mm256_and_pd(beyond, inf), _mm256_and_pd(below, sign)));
}

/// The 4×4 transpose of rows[0..4) into cols[0..4): cols[c][r] = rows[r][c].
[[gnu::target("avx"), gnu::always_inline]] inline void transposed_avx(const __m256d* rows,
                                                                      __m256d* cols) {
    const __m256d lo01 = _mm256_unpacklo_pd(rows[0], rows[1]);  // r0c0 r1c0 r0c2 r1c2
    const __m256d hi01 = _mm256_unpackhi_pd(rows[0], rows[1]);  // r0c1 r1c1 r0c3 r1c3
    const __m256d lo23 = _mm256_unpacklo_pd(rows[2], rows[3]);
    const __m256d hi23 = _mm256_unpackhi_pd(rows[2], rows[3]);
    cols[0] = _mm256_permute2f128_pd(lo01, lo23, 0x20);
    cols[1] = _mm256_permute2f128_pd(hi01, hi23, 0x20);
    cols[2] = _mm256_permute2f128_pd(lo01, lo23, 0x31);
    cols[3] = _mm256_permute2f128_pd(hi01, hi23, 0x31);
}

/// Rays k..k+3 (the last of rays[0..m) standing in for those past it), one vector per field:
/// ox, oy, oz, dx, dy, dz, tmin, tmax. Each ray's eight doubles are loaded as two vectors and
/// transposed.
[[gnu::target("avx"), gnu::always_inline]] inline void load_rays_avx(const Ray* rays, std::size_t k,
                                                                     std::size_t m, __m256d* col) {
    __m256d lo[4], hi[4];  // (ox, oy, oz, dx) and (dy, dz, tmin, tmax) of four rays
    for (std::size_t j = 0; j < 4; ++j) {
        const auto* p = reinterpret_cast<const double*>(&rays[std::min(k + j, m - 1)]);
        lo[j] = _mm256_loadu_pd(p);
        hi[j] = _mm256_loadu_pd(p + 4);
    }
    transposed_avx(lo, col);
    transposed_avx(hi, col + 4);
}

/// The fields fill_lane writes alike in every lane (time 0, every mask bit, the lane's id, no
/// flags), for the fills that write the rays four lanes at a time.
void fill_lane_constants(RTCRay16& r16) {
    for (std::size_t k = 0; k < kLanes; ++k) {
        r16.time[k] = 0.0f;
        r16.mask[k] = 0xFFFFFFFFu;  // as fill_lane
        r16.id[k] = static_cast<unsigned>(k);
        r16.flags[k] = 0;
    }
}

/// The same, four rays at a time in AVX's registers (load_rays_avx), unclipped_float_ray's tests
/// and conversions done on the four lanes at once, and the lanes stored four floats at a time.
/// The same operations in the same order as unclipped_float_ray (no FMA: the project builds
/// with -ffp-contract=off, and AVX without FMA has none), so the lanes are bit-identical
/// (`FastLanes.AvxFillsTheLanesOneByOneFills`). Done one ray at a time, the filling and the
/// coherence test were 11% of a Duck render at fast (perf, bench_render), half of what Embree's
/// own traversal took; four and eight lanes at a time, 5.5%.
[[gnu::target("avx")]] bool fill_fast_lanes_avx(const Impl& a, const Ray* rays, std::size_t m,
                                                RTCRay16& r16, int* valid) {
    const __m256d zero = _mm256_setzero_pd();
    const __m256d sign = _mm256_set1_pd(-0.0);
    const __m256d reach = _mm256_set1_pd(4.0 * a.float_scale);
    const __m256d d2_lo = _mm256_set1_pd(1e-12), d2_hi = _mm256_set1_pd(1e12);
    const __m256d cx = _mm256_set1_pd(a.center.x), cy = _mm256_set1_pd(a.center.y),
                  cz = _mm256_set1_pd(a.center.z);
    const __m256d unit = _mm256_set1_pd(a.unit);
    for (std::size_t k = 0; k < kLanes; k += 4) {
        __m256d col[8];  // ox, oy, oz, dx, then dy, dz, tmin, tmax: four rays each
        load_rays_avx(rays, k, m, col);
        const __m256d ox = col[0], oy = col[1], oz = col[2], dx = col[3];
        const __m256d dy = col[4], dz = col[5], tmin = col[6], tmax = col[7];
        // fast_ray_applies, lane by lane (ordered comparisons: false on a NaN).
        const __m256d qx = _mm256_sub_pd(ox, cx), qy = _mm256_sub_pd(oy, cy),
                      qz = _mm256_sub_pd(oz, cz);
        const __m256d d2 = _mm256_add_pd(
            _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)), _mm256_mul_pd(dz, dz));
        __m256d ok = _mm256_cmp_pd(tmin, zero, _CMP_GE_OQ);
        ok = _mm256_and_pd(ok, _mm256_cmp_pd(_mm256_andnot_pd(sign, qx), reach, _CMP_LE_OQ));
        ok = _mm256_and_pd(ok, _mm256_cmp_pd(_mm256_andnot_pd(sign, qy), reach, _CMP_LE_OQ));
        ok = _mm256_and_pd(ok, _mm256_cmp_pd(_mm256_andnot_pd(sign, qz), reach, _CMP_LE_OQ));
        ok = _mm256_and_pd(ok, _mm256_cmp_pd(d2, d2_lo, _CMP_GE_OQ));
        ok = _mm256_and_pd(ok, _mm256_cmp_pd(d2, d2_hi, _CMP_LE_OQ));
        if (_mm256_movemask_pd(ok) != 0xF)
            return false;
        // unclipped_float_ray's conversions; tnear and tfar saturate as to_float does.
        _mm_store_ps(r16.org_x + k, _mm256_cvtpd_ps(_mm256_mul_pd(qx, unit)));
        _mm_store_ps(r16.org_y + k, _mm256_cvtpd_ps(_mm256_mul_pd(qy, unit)));
        _mm_store_ps(r16.org_z + k, _mm256_cvtpd_ps(_mm256_mul_pd(qz, unit)));
        _mm_store_ps(r16.dir_x + k, _mm256_cvtpd_ps(dx));
        _mm_store_ps(r16.dir_y + k, _mm256_cvtpd_ps(dy));
        _mm_store_ps(r16.dir_z + k, _mm256_cvtpd_ps(dz));
        _mm_store_ps(r16.tnear + k, _mm256_cvtpd_ps(saturated_avx(_mm256_mul_pd(tmin, unit))));
        _mm_store_ps(r16.tfar + k, _mm256_cvtpd_ps(saturated_avx(_mm256_mul_pd(tmax, unit))));
    }
    fill_lane_constants(r16);
    for (std::size_t k = 0; k < kLanes; ++k)
        valid[k] = k < m ? -1 : 0;
    return true;
}

/// coherent() on a filled packet's 16 lanes in float, eight at a time in AVX's registers: the
/// same products and sums in the same order, so the same flag. Lane 0 compares with itself,
/// which coherent() skips: its lane is masked out. One lane at a time this test was a third of
/// the lane filling's time on the Duck (perf, bench_render).
[[gnu::target("avx")]] bool coherent_lanes_avx(const RTCRay16& r16, float max_spread2) {
    const __m256 d0x = _mm256_set1_ps(r16.dir_x[0]), d0y = _mm256_set1_ps(r16.dir_y[0]),
                 d0z = _mm256_set1_ps(r16.dir_z[0]);
    const __m256 o0x = _mm256_set1_ps(r16.org_x[0]), o0y = _mm256_set1_ps(r16.org_y[0]),
                 o0z = _mm256_set1_ps(r16.org_z[0]);
    const float d0d0_scalar =
        r16.dir_x[0] * r16.dir_x[0] + r16.dir_y[0] * r16.dir_y[0] + r16.dir_z[0] * r16.dir_z[0];
    const __m256 d0d0 = _mm256_set1_ps(d0d0_scalar);
    const __m256 zero = _mm256_setzero_ps();
    const __m256 cos2 = _mm256_set1_ps(0.97f);
    const __m256 spread = _mm256_set1_ps(max_spread2);
    __m256 incoherent = zero;
    for (std::size_t k = 0; k < kLanes; k += 8) {
        const __m256 dx = _mm256_load_ps(r16.dir_x + k), dy = _mm256_load_ps(r16.dir_y + k),
                     dz = _mm256_load_ps(r16.dir_z + k);
        const __m256 c = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(dx, d0x), _mm256_mul_ps(dy, d0y)), _mm256_mul_ps(dz, d0z));
        const __m256 dd = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
                                        _mm256_mul_ps(dz, dz));
        const __m256 ox = _mm256_sub_ps(_mm256_load_ps(r16.org_x + k), o0x),
                     oy = _mm256_sub_ps(_mm256_load_ps(r16.org_y + k), o0y),
                     oz = _mm256_sub_ps(_mm256_load_ps(r16.org_z + k), o0z);
        const __m256 oo = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ox, ox), _mm256_mul_ps(oy, oy)),
                                        _mm256_mul_ps(oz, oz));
        __m256 bad = _mm256_cmp_ps(c, zero, _CMP_LE_OQ);
        bad = _mm256_or_ps(
            bad, _mm256_cmp_ps(_mm256_mul_ps(c, c), _mm256_mul_ps(_mm256_mul_ps(cos2, dd), d0d0),
                               _CMP_LT_OQ));
        bad = _mm256_or_ps(bad, _mm256_cmp_ps(oo, spread, _CMP_GT_OQ));
        if (k == 0)  // lane 0 is the reference itself
            bad = _mm256_blend_ps(bad, zero, 0x1);
        incoherent = _mm256_or_ps(incoherent, bad);
    }
    return _mm256_movemask_ps(incoherent) == 0;
}

/// length() of four vectors (x, y, z), as length() forms it: √((x² + y²) + z²).
[[gnu::target("avx"), gnu::always_inline]] inline __m256d length_avx(__m256d x, __m256d y,
                                                                     __m256d z) {
    return _mm256_sqrt_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(x, x), _mm256_mul_pd(y, y)),
                                        _mm256_mul_pd(z, z)));
}

/// Four 64-bit lane masks as four 32-bit ones.
[[gnu::target("avx"), gnu::always_inline]] inline __m128 narrowed(__m256d mask) {
    return _mm_shuffle_ps(_mm256_castps256_ps128(_mm256_castpd_ps(mask)),
                          _mm256_extractf128_ps(_mm256_castpd_ps(mask), 1),
                          _MM_SHUFFLE(2, 0, 2, 0));
}

/// float_up on four lanes: each value rounded to float, stepped up to the next float where
/// that went down (next_up's bit steps: +1 above zero, −1 below, the least subnormal from
/// either zero, +∞ and NaN as they are).
[[gnu::target("avx"), gnu::always_inline]] inline __m128 float_up_avx(__m256d v) {
    const __m128 f = _mm256_cvtpd_ps(v);
    const __m128 take_up = narrowed(_mm256_cmp_pd(_mm256_cvtps_pd(f), v, _CMP_LT_OQ));
    const __m128 zero = _mm_setzero_ps();
    const __m128i bits = _mm_castps_si128(f), one = _mm_set1_epi32(1);
    const __m128 above = _mm_castsi128_ps(_mm_add_epi32(bits, one));
    const __m128 below = _mm_castsi128_ps(_mm_sub_epi32(bits, one));
    __m128 up = _mm_blendv_ps(below, above, _mm_cmpgt_ps(f, zero));
    up = _mm_blendv_ps(up, _mm_castsi128_ps(one), _mm_cmpeq_ps(f, zero));  // denorm_min
    up = _mm_blendv_ps(f, up, _mm_cmplt_ps(f, _mm_set1_ps(std::numeric_limits<float>::infinity())));
    return _mm_blendv_ps(f, up, take_up);
}

/// What four_backed_off_lanes_avx made of four lanes (bit j each).
struct FourLanes {
    alignas(32) double shift[4], len[4], origin_err[4];
    int on = 0;   ///< set up, as prepare_ray would: valid, context below
    int off = 0;  ///< prepare_ray's false (the segment misses the bounds): valid 0
    // The others: a ray that takes another branch of prepare_ray (a zero or NaN direction
    // component, a length beyond 2^±500, an origin far enough for the double-double start
    // point, a start point it leaves unplaced), left to prepare_ray itself.
};

/// prepare_ray (RayStart::backed_off, RayFrame::world) on rays k..k+3, in AVX's registers: the
/// same operations in the same order (clip_to_bounds' slabs, with its min/max operand order;
/// no FMA: -ffp-contract=off), so the same bits. The float rays go straight into lanes k..k+3
/// of r16 (fill_lane's values: an off lane's FloatRay{} with tfar −1; the lanes left to
/// prepare_ray are written again by it).
[[gnu::target("avx")]] void four_backed_off_lanes_avx(const Impl& a, const Ray* rays, std::size_t k,
                                                      std::size_t m, RTCRay16& r16,
                                                      FourLanes& out) {
    const __m256d zero = _mm256_setzero_pd();
    const __m256d sign = _mm256_set1_pd(-0.0);
    const __m256d g3 = _mm256_set1_pd(gamma(3));
    const __m256d one = _mm256_set1_pd(1.0);
    const __m256d inf = _mm256_set1_pd(std::numeric_limits<double>::infinity());
    __m256d col[8];  // ox, oy, oz, dx, dy, dz, tmin, tmax: four rays each
    load_rays_avx(rays, k, m, col);
    // clip_to_bounds against the padded bounds (its other branch, for a zero direction
    // component, is prepare_ray's: such a lane is not sloped).
    __m256d lo_t = col[6], hi_t = col[7];
    __m256d sloped = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
    for (int j = 0; j < 3; ++j) {
        const __m256d o = col[j], d = col[3 + j];
        sloped = _mm256_and_pd(sloped, _mm256_cmp_pd(d, zero, _CMP_NEQ_OQ));
        const __m256d inv = _mm256_div_pd(one, d);
        const __m256d tl =
            _mm256_mul_pd(_mm256_sub_pd(_mm256_set1_pd(a.padded_bounds.lo[j]), o), inv);
        const __m256d th =
            _mm256_mul_pd(_mm256_sub_pd(_mm256_set1_pd(a.padded_bounds.hi[j]), o), inv);
        const __m256d ta = _mm256_min_pd(th, tl), tb = _mm256_max_pd(tl, th);  // ordered()
        // std::max(lo_t, x) is max_pd(x, lo_t), std::min(hi_t, y) is min_pd(y, hi_t), NaNs
        // and signed zeros alike.
        lo_t =
            _mm256_max_pd(_mm256_sub_pd(ta, _mm256_mul_pd(g3, _mm256_andnot_pd(sign, ta))), lo_t);
        hi_t =
            _mm256_min_pd(_mm256_add_pd(tb, _mm256_mul_pd(g3, _mm256_andnot_pd(sign, tb))), hi_t);
    }
    const __m256d meets = _mm256_cmp_pd(lo_t, hi_t, _CMP_LE_OQ);
    const __m256d dx = col[3], dy = col[4], dz = col[5];
    const __m256d dlen = length_avx(dx, dy, dz);
    __m256d ok = _mm256_and_pd(_mm256_and_pd(sloped, meets),
                               _mm256_cmp_pd(dlen, _mm256_set1_pd(0x1p-500), _CMP_GT_OQ));
    ok = _mm256_and_pd(ok, _mm256_cmp_pd(dlen, _mm256_set1_pd(0x1p500), _CMP_LT_OQ));
    const __m256d len = _mm256_mul_pd(dlen, _mm256_set1_pd(a.unit));
    const __m256d shift = _mm256_sub_pd(lo_t, _mm256_div_pd(_mm256_set1_pd(4.0 * a.pad), dlen));
    const __m256d qx = _mm256_sub_pd(col[0], _mm256_set1_pd(a.center.x)),
                  qy = _mm256_sub_pd(col[1], _mm256_set1_pd(a.center.y)),
                  qz = _mm256_sub_pd(col[2], _mm256_set1_pd(a.center.z));
    const __m256d far =
        _mm256_add_pd(length_avx(qx, qy, qz), _mm256_mul_pd(_mm256_andnot_pd(sign, shift), dlen));
    const __m256d origin_err = _mm256_mul_pd(_mm256_set1_pd(8.0 * kDoubleUnitRoundoff), far);
    ok = _mm256_and_pd(ok, _mm256_cmp_pd(origin_err, _mm256_set1_pd(0.25 * a.pad), _CMP_LE_OQ));
    const __m256d org[3] = {_mm256_add_pd(qx, _mm256_mul_pd(dx, shift)),
                            _mm256_add_pd(qy, _mm256_mul_pd(dy, shift)),
                            _mm256_add_pd(qz, _mm256_mul_pd(dz, shift))};
    const __m256d inv_len = _mm256_div_pd(one, dlen);
    // prepare_ray's checks before it places the start point (ordered comparisons: a NaN fails).
    const __m256d reach = _mm256_set1_pd(4.0 * a.float_scale);
    for (int j = 0; j < 3; ++j)
        ok = _mm256_and_pd(ok, _mm256_cmp_pd(_mm256_andnot_pd(sign, org[j]), reach, _CMP_LE_OQ));
    ok = _mm256_and_pd(ok, _mm256_cmp_pd(len, zero, _CMP_GT_OQ));
    ok = _mm256_and_pd(ok, _mm256_cmp_pd(len, inf, _CMP_LT_OQ));
    const double margin = float_margin(a);
    const __m256d margin_over_len =
        _mm256_andnot_pd(sign, _mm256_div_pd(_mm256_set1_pd(margin), len));
    ok = _mm256_and_pd(ok, _mm256_cmp_pd(margin_over_len, inf, _CMP_LT_OQ));
    // tfar: +∞ for an infinite end (std::isinf), else tfar_for's float_up((t1 − shift)·len +
    // margin); a NaN is left to prepare_ray (it leaves the ray unplaced).
    const __m128 tf_up = float_up_avx(
        _mm256_add_pd(_mm256_mul_pd(_mm256_sub_pd(hi_t, shift), len), _mm256_set1_pd(margin)));
    const __m128 endless = narrowed(_mm256_cmp_pd(_mm256_andnot_pd(sign, hi_t), inf, _CMP_EQ_OQ));
    const __m128 tf =
        _mm_blendv_ps(tf_up, _mm_set1_ps(std::numeric_limits<float>::infinity()), endless);
    out.on = _mm256_movemask_pd(ok) & _mm_movemask_ps(_mm_cmpord_ps(tf, tf));
    out.off = _mm256_movemask_pd(_mm256_andnot_pd(meets, sloped));
    // The lanes: the float ray where on, FloatRay{} (tfar −1) where off or left (those are
    // written again by prepare_ray).
    const __m128 on4 = _mm_and_ps(narrowed(ok), _mm_cmpord_ps(tf, tf));
    const __m256d unit = _mm256_set1_pd(a.unit);
    const __m256d dir[3] = {dx, dy, dz};
    float* const org_out[3] = {r16.org_x + k, r16.org_y + k, r16.org_z + k};
    float* const dir_out[3] = {r16.dir_x + k, r16.dir_y + k, r16.dir_z + k};
    for (int j = 0; j < 3; ++j) {
        _mm_store_ps(org_out[j],
                     _mm_and_ps(on4, _mm256_cvtpd_ps(saturated_avx(_mm256_mul_pd(org[j], unit)))));
        _mm_store_ps(dir_out[j], _mm_and_ps(on4, _mm256_cvtpd_ps(_mm256_mul_pd(dir[j], inv_len))));
    }
    _mm_store_ps(r16.tnear + k, _mm_setzero_ps());
    _mm_store_ps(r16.tfar + k, _mm_blendv_ps(_mm_set1_ps(-1.0f), tf, on4));
    _mm256_store_pd(out.shift, shift);
    _mm256_store_pd(out.len, len);
    _mm256_store_pd(out.origin_err, origin_err);
}

/// fast_packet's answers one lane at a time: fast_hit with fast's unclipped mapping (shift 0,
/// len Impl::unit), a miss as Hit{}.
void fast_answers_scalar(const Impl& a, const Ray* rays, std::size_t m, const RTCRayHit16& rh,
                         bool want_normal, Hit* out) {
    for (std::size_t k = 0; k < m; ++k) {
        if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) {
            out[k] = Hit{};  // fast takes a float miss as it is
            continue;
        }
        fast_hit(a, rays[k], 0.0, a.unit, native_hit(rh, k), want_normal, out[k]);
    }
}

/// The same four lanes at a time in AVX's registers: fast_hit's three square roots and five
/// divisions a hit, which one at a time waited on each other (5–6% of a Duck render at fast,
/// perf), done four lanes to an instruction, in the same order as fast_hit (so the same bits:
/// `FastLanes.AvxAnswersAsOneByOne`), and the Hits written lane by lane from there.
[[gnu::target("avx")]] void fast_answers_avx(const Impl& a, const Ray* rays, std::size_t m,
                                             const RTCRayHit16& rh, bool want_normal, Hit* out) {
    const __m256d zero = _mm256_setzero_pd();
    const __m256d sign = _mm256_set1_pd(-0.0);
    const __m256d len = _mm256_set1_pd(a.unit);
    const __m256d cx = _mm256_set1_pd(a.center.x), cy = _mm256_set1_pd(a.center.y),
                  cz = _mm256_set1_pd(a.center.z);
    const __m256d scale = _mm256_set1_pd(a.float_scale);
    const __m256d gamma12 = _mm256_set1_pd(gamma_float(12));
    for (std::size_t k = 0; k < m; k += 4) {
        __m256d col[8];
        load_rays_avx(rays, k, m, col);
        const __m256d dx = col[3], dy = col[4], dz = col[5], tmin = col[6], tmax = col[7];
        // t = min(max(0 + tfar/len, tmin), tmax): std::max(x, tmin) is max_pd(tmin, x) and
        // std::min(y, tmax) is min_pd(tmax, y), NaNs and zeros alike.
        const __m256d tf = _mm256_cvtps_pd(_mm_load_ps(rh.ray.tfar + k));
        const __m256d t =
            _mm256_min_pd(tmax, _mm256_max_pd(tmin, _mm256_add_pd(zero, _mm256_div_pd(tf, len))));
        // t_err = γ_f(12)·((scale + |o − centre|)/|d| + |t|)
        const __m256d dist = length_avx(_mm256_sub_pd(col[0], cx), _mm256_sub_pd(col[1], cy),
                                        _mm256_sub_pd(col[2], cz));
        const __m256d t_err = _mm256_mul_pd(
            gamma12,
            _mm256_add_pd(_mm256_div_pd(_mm256_add_pd(scale, dist), length_avx(dx, dy, dz)),
                          _mm256_andnot_pd(sign, t)));
        const __m256d ngx = _mm256_cvtps_pd(_mm_load_ps(rh.hit.Ng_x + k)),
                      ngy = _mm256_cvtps_pd(_mm_load_ps(rh.hit.Ng_y + k)),
                      ngz = _mm256_cvtps_pd(_mm_load_ps(rh.hit.Ng_z + k));
        const __m256d facing = _mm256_add_pd(
            _mm256_add_pd(_mm256_mul_pd(dx, ngx), _mm256_mul_pd(dy, ngy)), _mm256_mul_pd(dz, ngz));
        const int front = _mm256_movemask_pd(_mm256_cmp_pd(facing, zero, _CMP_LT_OQ));
        alignas(32) double ts[4], errs[4], us[4], vs[4], nx[4] = {}, ny[4] = {}, nz[4] = {};
        _mm256_store_pd(ts, t);
        _mm256_store_pd(errs, t_err);
        _mm256_store_pd(us, _mm256_cvtps_pd(_mm_load_ps(rh.hit.u + k)));
        _mm256_store_pd(vs, _mm256_cvtps_pd(_mm_load_ps(rh.hit.v + k)));
        if (want_normal) {
            const __m256d l = length_avx(ngx, ngy, ngz);
            const __m256d some = _mm256_cmp_pd(l, zero, _CMP_GT_OQ);  // else the zero vector
            _mm256_store_pd(nx, _mm256_and_pd(some, _mm256_div_pd(ngx, l)));
            _mm256_store_pd(ny, _mm256_and_pd(some, _mm256_div_pd(ngy, l)));
            _mm256_store_pd(nz, _mm256_and_pd(some, _mm256_div_pd(ngz, l)));
        }
        for (std::size_t j = 0; j < 4 && k + j < m; ++j) {
            Hit& h = out[k + j];
            if (rh.hit.geomID[k + j] == RTC_INVALID_GEOMETRY_ID) {
                h = Hit{};  // fast takes a float miss as it is
                continue;
            }
            h.t = ts[j];
            h.t_err = errs[j];
            h.object = rh.hit.geomID[k + j];
            h.primitive = rh.hit.primID[k + j];
            h.u = us[j];
            h.v = vs[j];
            h.front_face = ((front >> j) & 1) != 0;
            h.on_edge = false;
            h.normal = Vec3d{nx[j], ny[j], nz[j]};
        }
    }
}

}  // namespace

void fast_packet_answers(const Impl& a, const Ray* rays, std::size_t m, const RTCRayHit16& rh,
                         bool want_normal, Hit* out, FastLanes how) {
    if (how == FastLanes::avx && widest_fast_lanes() == FastLanes::avx) {
        fast_answers_avx(a, rays, m, rh, want_normal, out);
    } else {
        fast_answers_scalar(a, rays, m, rh, want_normal, out);
    }
}

FastLanes widest_fast_lanes() {
    return cpu_has_avx() ? FastLanes::avx : FastLanes::one_by_one;
}

std::optional<RTCIntersectContext> fill_fast_lanes(const Impl& a, const Ray* rays, std::size_t m,
                                                   RTCRay16& r16, int* valid, FastLanes how) {
    const float spread2 = to_float(0.0025 * (a.float_scale * a.unit) * (a.float_scale * a.unit));
    if (how == FastLanes::avx && widest_fast_lanes() == FastLanes::avx) {
        if (!fill_fast_lanes_avx(a, rays, m, r16, valid))
            return std::nullopt;
        return flagged_context(coherent_lanes_avx(r16, spread2));
    }
    if (!fill_fast_lanes_scalar(a, rays, m, r16, valid))
        return std::nullopt;
    const bool together = coherent(
        kLanes,
        [&r16](std::size_t k) {
            return Vec3f{r16.dir_x[k], r16.dir_y[k], r16.dir_z[k]};
        },
        [&r16](std::size_t k) {
            return Vec3f{r16.org_x[k], r16.org_y[k], r16.org_z[k]};
        },
        spread2);
    return flagged_context(together);
}

[[gnu::target("avx")]] void float_up_four_avx(const double* in, float* out) {
    _mm_storeu_ps(out, float_up_avx(_mm256_loadu_pd(in)));
}

unsigned backed_off_lanes_avx(const Impl& a, const Ray* rays, std::size_t m, bool want_normal,
                              RayContext* lanes, RTCRay16& r16, int* valid) {
    unsigned left = 0;
    const double margin = float_margin(a);
    fill_lane_constants(r16);
    for (std::size_t k = 0; k < m; k += 4) {
        FourLanes four;
        four_backed_off_lanes_avx(a, rays, k, m, r16, four);
        for (std::size_t j = 0; j < 4 && k + j < m; ++j) {
            const std::size_t lane = k + j;
            RayContext& c = lanes[lane];
            if (four.on >> j & 1) {
                c.accel = &a;
                c.want_normal = want_normal;  // as prepare_refined_closest_ray
                c.ray = &rays[lane];
                c.frame = nullptr;
                c.far = false;
                c.len = four.len[j];
                c.margin = margin;
                c.shift = four.shift[j];
                c.origin_err = four.origin_err[j];
                valid[lane] = -1;
            } else if (four.off >> j & 1) {  // prepare_ray's false, which sets nothing else
                c.accel = &a;
                c.want_normal = want_normal;
                valid[lane] = 0;
            } else {
                left |= 1u << lane;
            }
        }
    }
    for (std::size_t lane = m; lane < kLanes; ++lane)  // fill_lanes' own
        left |= 1u << lane;
    return left;
}

bool fast_packet(const Impl& a, RTCScene scene, const Ray* rays, std::size_t m, bool want_normal,
                 Hit* out) {
    alignas(64) RTCRayHit16 rh;
    alignas(64) int valid[kLanes];
    std::optional<RTCIntersectContext> ctx = fill_fast_lanes(a, rays, m, rh.ray, valid);
    if (!ctx)
        return false;
    for (std::size_t k = 0; k < kLanes; ++k)
        rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect16(valid, scene, &*ctx, &rh);
    fast_packet_answers(a, rays, m, rh, want_normal, out);
    return true;
}

bool fast_any_packet(const Impl& a, RTCScene scene, const Ray* rays, std::size_t m,
                     std::uint8_t* out) {
    alignas(64) RTCRay16 r16;
    alignas(64) int valid[kLanes];
    std::optional<RTCIntersectContext> ctx = fill_fast_lanes(a, rays, m, r16, valid);
    if (!ctx)
        return false;
    rtcOccluded16(valid, scene, &*ctx, &r16);
    for (std::size_t k = 0; k < m; ++k)
        out[k] = occluded_tfar(r16.tfar[k]) ? 1 : 0;  // fast takes a float miss as it is
    return true;
}

}  // namespace raycastd::engine::embree
