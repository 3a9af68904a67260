#pragma once
// The first stage of Woop's watertight test (Woop, Benthin & Wald, "Watertight Ray/Triangle
// Intersection", JCGT 2(1), 2013, §3 and eq. 2): the ray's shear frame, the triangle's corners
// relative to the origin sheared so that the ray runs along +z, and the three 2-D edge functions
// U, V, W at the origin. triangle.cpp's woop() forms them with these functions, and so does
// woop_misses() below, for a caller that meets many triangles with one ray (exact's BVH walks;
// not the scene scan, where it cost more than it saved: docs/numerics.md): it forms the ray's
// part once and rejects, with the same bits and so the same decision, the candidates whose edge
// functions alone settle a miss, without the rest of woop() (its rescaling checks, the settling
// of uncertain signs, the plane crossing, a Hit returned through memory). On A's camera rays 1.9 of
// an exact query's 2.76 candidates a ray are such misses, and woop() took about 226 instructions
// for each (callgrind, 2026-12-07).

#include <cmath>
#include <cstddef>
#include <cstring>

#include <immintrin.h>

#include "engine/geometry/triangle.h"
#include "engine/math/float_bounds.h"
#include "engine/math/ray.h"

namespace raycastd::engine {

/// The ray's shear frame: kz is the dominant axis of the direction; kx, ky are chosen so that
/// the winding (and therefore the sign convention of U, V, W) is preserved (Woop et al. §3).
struct ShearFrame {
    std::size_t kx, ky, kz;
    double sx, sy, sz;
};

inline ShearFrame make_shear(const Vec3d& d) {
    ShearFrame s{};
    s.kz = max_abs_dimension(d);
    s.kx = (s.kz + 1) % 3;
    s.ky = (s.kx + 1) % 3;
    if (d[s.kz] < 0.0) {
        const std::size_t k = s.kx;
        s.kx = s.ky;
        s.ky = k;
    }
    s.sx = d[s.kx] / d[s.kz];
    s.sy = d[s.ky] / d[s.kz];
    s.sz = 1.0 / d[s.kz];
    return s;
}

static_assert(sizeof(Vec3d) == 3 * sizeof(double), "Vec3d is three doubles, unpadded");

/// Component k of v as one load from its bytes (Vec3d's operator[] is a chain of selects, which
/// a runtime index compiles to compares and conditional moves).
inline double component(const Vec3d& v, std::size_t k) {
    double out;
    std::memcpy(&out, reinterpret_cast<const char*>(&v) + k * sizeof(double), sizeof out);
    return out;
}

/// The sheared corners' x and y (eq. 2) and the edge functions, scaled barycentrics, of the
/// corners A, B, C relative to the origin.
struct ShearedEdges {
    double ax, ay, bx, by, cx, cy;
    double u, v, w;
};

inline ShearedEdges sheared_edges(const Vec3d& A, const Vec3d& B, const Vec3d& C,
                                  const ShearFrame& s) {
    ShearedEdges e;
    const double az = component(A, s.kz), bz = component(B, s.kz), cz = component(C, s.kz);
    e.ax = component(A, s.kx) - s.sx * az;
    e.ay = component(A, s.ky) - s.sy * az;
    e.bx = component(B, s.kx) - s.sx * bz;
    e.by = component(B, s.ky) - s.sy * bz;
    e.cx = component(C, s.kx) - s.sx * cz;
    e.cy = component(C, s.ky) - s.sy * cz;
    e.u = e.cx * e.by - e.cy * e.bx;
    e.v = e.ax * e.cy - e.ay * e.cx;
    e.w = e.bx * e.ay - e.by * e.ax;
    return e;
}

/// Whether the edge functions and the direction's dominant component `dm` (|d_kz|) are at a
/// scale where woop() takes them as they are; else it brings triangle and ray to unit scale
/// first (woop_rescaled, triangle.cpp, says why). A sum, not std::max, which drops a NaN (inf −
/// inf at a corner of a triangle 1e160 across): the NaN then fails the test and is rescaled.
inline bool edges_in_scale(const ShearedEdges& e, double dm) {
    const double m = std::abs(e.u) + std::abs(e.v) + std::abs(e.w);
    return m >= 0x1p-600 && m <= 0x1p600 && dm >= 0x1p-250 && dm <= 0x1p250;
}

/// Whether the edge function `e` of the corners p, q (their largest coordinates relative to the
/// origin `mp`, `mq`) has a certain sign: it exceeds its rounding bound γ₁₆·8·mp·mq (woop's
/// settle_edge says where the bound comes from; (mp·mq) formed first, so that both triangles
/// of an edge round it alike).
inline bool edge_sign_certain(double e, double mp, double mq) {
    constexpr double k = 8.0 * gamma(16);
    return std::abs(e) > k * (mp * mq);
}

/// The ray's part of the first stage, formed once.
struct WoopRay {
    Vec3d origin;
    ShearFrame s;
    double dm;  ///< |d_kz|
};

inline WoopRay woop_ray(const Ray& ray) {
    WoopRay r;
    r.origin = ray.origin;
    r.s = make_shear(ray.direction);
    r.dm = std::abs(component(ray.direction, r.s.kz));
    return r;
}

/// True where intersect_triangle, decide_triangle and intersect_triangle_fast (triangle.h)
/// certainly answer no hit for `tri` and the ray of `r`: at the scale woop() decides at, two of
/// the edge functions clear their rounding bounds with opposite signs, which woop() answers
/// with no hit whatever the third settles to (and without noting a LineCrossing). The same
/// operations on the same values as woop()'s, so the same bits. False says nothing.
inline bool woop_misses(const Triangle& tri, const WoopRay& r) {
    const Vec3d A = tri.a - r.origin, B = tri.b - r.origin, C = tri.c - r.origin;
    const ShearedEdges e = sheared_edges(A, B, C, r.s);
    if (!edges_in_scale(e, r.dm))
        return false;
    const double ma = max_abs(A), mb = max_abs(B), mc = max_abs(C);
    const bool cu = edge_sign_certain(e.u, mc, mb);
    const bool cv = edge_sign_certain(e.v, ma, mc);
    const bool cw = edge_sign_certain(e.w, mb, ma);
    const bool negative = (cu && e.u < 0.0) || (cv && e.v < 0.0) || (cw && e.w < 0.0);
    const bool positive = (cu && e.u > 0.0) || (cv && e.v > 0.0) || (cw && e.w > 0.0);
    return negative && positive;
}

namespace detail {

/// The lanes (v₂, v₀, v₁, v₂) of v (the fourth is never read): each edge function's first
/// factor from its second's.
[[gnu::target("avx")]] inline __m256d rotate_lanes(__m256d v) {
    return _mm256_shuffle_pd(_mm256_permute2f128_pd(v, v, 1), v, 0b0100);
}

/// Coordinate k of the corners pa, pb, pc relative to the origin, in lanes 0, 1, 2.
[[gnu::target("avx")]] inline __m256d corners_on_axis(const Vec3d& pa, const Vec3d& pb,
                                                      const Vec3d& pc, const Vec3d& origin,
                                                      std::size_t k) {
    return _mm256_sub_pd(_mm256_set_pd(0.0, component(pc, k), component(pb, k), component(pa, k)),
                         _mm256_set1_pd(component(origin, k)));
}

}  // namespace detail

/// woop_misses for the triangle of corners pa, pb, pc, with AVX: the corners' coordinates on
/// each of the shear's axes in the lanes of one register (a, b, c, and a fourth lane that
/// nothing reads), the lanes rotated to pair each edge function's terms. Each lane performs
/// woop_misses' operations on its values (the corner minus the origin by component, the
/// shear's product and difference, the edge function's two products and their difference,
/// the bound's products; a maximum rounds nothing), so it forms the same bits and gives the
/// same answer (the project builds with -ffp-contract=off). Only where the processor has AVX
/// (cpu_has_avx). Inline, so that exact's walk, compiled for AVX, has it in line.
[[gnu::target("avx")]] inline bool woop_misses_avx(const Vec3d& pa, const Vec3d& pb,
                                                   const Vec3d& pc, const WoopRay& r) {
    using detail::rotate_lanes;
    const ShearFrame& s = r.s;
    const __m256d x = detail::corners_on_axis(pa, pb, pc, r.origin, s.kx);
    const __m256d y = detail::corners_on_axis(pa, pb, pc, r.origin, s.ky);
    const __m256d z = detail::corners_on_axis(pa, pb, pc, r.origin, s.kz);
    const __m256d sx = _mm256_sub_pd(x, _mm256_mul_pd(_mm256_set1_pd(s.sx), z));
    const __m256d sy = _mm256_sub_pd(y, _mm256_mul_pd(_mm256_set1_pd(s.sy), z));
    // Lanes (c, a, b) and (b, c, a) of the sheared coordinates: u = cx·by − cy·bx,
    // v = ax·cy − ay·cx, w = bx·ay − by·ax in lanes 0, 1, 2.
    const __m256d sx1 = rotate_lanes(sx), sy1 = rotate_lanes(sy);
    const __m256d sx2 = rotate_lanes(sx1), sy2 = rotate_lanes(sy1);
    const __m256d e = _mm256_sub_pd(_mm256_mul_pd(sx1, sy2), _mm256_mul_pd(sy1, sx2));
    // Each corner's max_abs relative to the origin (ma, mb, mc), and the bounds
    // k·(mc·mb, ma·mc, mb·ma).
    const __m256d sign = _mm256_set1_pd(-0.0);
    const __m256d m =
        _mm256_max_pd(_mm256_max_pd(_mm256_andnot_pd(sign, x), _mm256_andnot_pd(sign, y)),
                      _mm256_andnot_pd(sign, z));
    const __m256d m1 = rotate_lanes(m), m2 = rotate_lanes(m1);
    const __m256d bound = _mm256_mul_pd(_mm256_set1_pd(8.0 * gamma(16)), _mm256_mul_pd(m1, m2));
    const __m256d certain = _mm256_cmp_pd(_mm256_andnot_pd(sign, e), bound, _CMP_GT_OQ);
    const __m256d zero = _mm256_setzero_pd();
    const int negative =
        _mm256_movemask_pd(_mm256_and_pd(certain, _mm256_cmp_pd(e, zero, _CMP_LT_OQ))) & 7;
    const int positive =
        _mm256_movemask_pd(_mm256_and_pd(certain, _mm256_cmp_pd(e, zero, _CMP_GT_OQ))) & 7;
    if (!(negative && positive))
        return false;
    // The scale woop() decides at (edges_in_scale), from the edge functions in its order.
    alignas(32) double lanes[4];
    _mm256_store_pd(lanes, e);
    ShearedEdges in_order{};
    in_order.u = lanes[0];
    in_order.v = lanes[1];
    in_order.w = lanes[2];
    return edges_in_scale(in_order, r.dm);
}

}  // namespace raycastd::engine
