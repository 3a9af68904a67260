#include "engine/accel/scene_scan.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include <immintrin.h>

#include "engine/geometry/target_clones.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine {

TrianglePlane TrianglePlane::of(const Triangle& tri) {
    TrianglePlane p;
    const Vec3d e1 = tri.b - tri.a, e2 = tri.c - tri.a;
    p.n = cross(e1, e2);
    // plane_t's bound on the rounded normal (cross_magnitudes).
    const Vec3d m = cross_magnitudes(e1, e2);
    const Vec3d n_err = gamma(5) * m;
    const Vec3d an = abs(p.n);
    const double dd_scale = 0x1p-96 * (an.x + an.y + an.z + m.x + m.y + m.z);
    // left_behind's bounds, per unit of |o − a| and of |d| by component: the rounded normal's
    // error times the other factor, and the rounding of o − a and of the dot products (γ₅ and γ₄
    // of the magnitudes), and for s plane_t's double-double resolution, whose dd_scale·|o − a|∞
    // is at most dd_scale·Σ|o − a|ᵢ. The factor 1.0001 leaves room for the rounding of these sums
    // and of the ray's dot products with them (a few ulps).
    p.s_err = 1.0001 * (n_err + gamma(5) * an + Vec3d{dd_scale, dd_scale, dd_scale});
    p.sd_err = 1.0001 * (n_err + gamma(4) * an);
    // A product that underflows breaks the relative bounds above (and the kernels' own): such
    // a triangle (edge components below ~1e-150) is never skipped. A zero factor is exact.
    const Vec3d a1 = abs(e1), a2 = abs(e2);
    const double f1[6] = {a1.y, a1.z, a1.z, a1.x, a1.x, a1.y};
    const double f2[6] = {a2.z, a2.y, a2.x, a2.z, a2.y, a2.x};
    p.usable = std::isfinite(dd_scale) && is_finite(p.s_err);
    for (int k = 0; k < 6; ++k)
        p.usable = p.usable && (f1[k] == 0.0 || f2[k] == 0.0 || f1[k] * f2[k] >= 0x1p-1000);
    return p;
}

namespace {

/// TrianglePlane::left_behind's body, inlined into both scans as it was until GCC stopped
/// inlining the member into SceneScan::closest when that grew (the out-of-line call showed as 7%
/// of the render in perf; forced back in, three alternating pairs of bench_render's
/// tutorial_like rows at fast were within the machine's noise: means 4,890 → 4,882 ms).
template <bool kBeyondToo>
[[gnu::always_inline]] inline bool left_behind(const TrianglePlane& plane, const Ray& ray,
                                               const Vec3d& a) {
    const Vec3d& n = plane.n;
    const Vec3d& s_err = plane.s_err;
    const Vec3d& sd_err = plane.sd_err;
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
    // The bounds' factors are summed once per triangle (TrianglePlane::of). n·d first: a ray
    // moving along the plane's side it starts on is rarer than one that is not, and that test
    // needs no origin.
    // A dot product that overflowed has no trustworthy sign (one product +inf, the others huge
    // and negative): the kernels decide (a helper's probe: a triangle 1e100 across seen from
    // 1e108 had s = +inf for a true s of −1e308, and was skipped though hit, where the bound
    // summed per ray had overflowed with s and never skipped).
    constexpr double kMax = std::numeric_limits<double>::max();
    if (!plane.usable || !(ray.tmin >= 0.0))
        return false;
    const Vec3d& d = ray.direction;
    const double sd = dot(n, d);
    const double sd_bound = dot(sd_err, abs(d)) + 0x1p-1000;
    if (!(std::abs(sd) > sd_bound && std::abs(sd) <= kMax))
        return false;
    const Vec3d oa = ray.origin - a;
    const double s = dot(n, oa);
    if (!(std::abs(s) <= kMax))
        return false;
    const double s_bound = dot(s_err, abs(oa)) + 0x1p-1000;
    if (sd > 0.0 ? s > s_bound : s < -s_bound)
        return true;
    if constexpr (kBeyondToo) {
        // Not left behind, so where |s| clears its bound s and n·d have opposite signs beyond
        // theirs: the line crosses ahead, at t = |s*|/|n·d*| ≥ (|s| − s_bound)/(|n·d| +
        // sd_bound) for the exact s* and n·d*. Past tmax by more than plane_t's own error (an
        // ulp or two, or the double-double resolution already in s_bound) neither kernel
        // reports the hit: plane_t's t is beyond tmax, and the fast kernel's sheared t, within
        // its t_err of the crossing, is beyond it too wherever t_err < t − tmax (a grazing ray
        // whose t_err exceeds that could have been taken up to t_err early; fast answers within
        // t_err, and a miss here is the crossing's true side). The factor 1 + 2⁻⁴⁰ covers the
        // rounding of both sides (a few ulps) and plane_t's error with room. tmax = +inf makes
        // the right side inf: never taken. Most of these are a closest ray's triangles behind
        // a surface it already hit: 2.9M of the 11.7M Woop tests of bench_render's three
        // tutorial_like renders at fast (counted 2026-12-07).
        return std::abs(s) - s_bound > ray.tmax * (std::abs(sd) + sd_bound) * (1.0 + 0x1p-40);
    }
    return false;
}

}  // namespace

bool TrianglePlane::left_behind(const Ray& ray, const Vec3d& a) const {
    return engine::left_behind<false>(*this, ray, a);
}

bool TrianglePlane::missed(const Ray& ray, const Vec3d& a) const {
    return engine::left_behind<true>(*this, ray, a);
}

namespace {
/// The rule's function for `lanes`: four taken as two where the processor has no AVX.
detail::RuledOut ruled_out_in(SceneScan::Lanes lanes);
}  // namespace

SceneScan::SceneScan(const Scene& scene, bool fast) : ball_(scene_ball(scene)), fast_(fast) {
    std::uint32_t spheres = 0;
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        const Object& o = scene.objects[i];
        if (o.kind == ObjectKind::sphere) {
            const std::uint32_t k = spheres++;
            sphere_list_.push_back(ScanSphere{o.sphere, i});
            if (k < 32)
                sphere_bits_ |= std::uint32_t{1} << k;
            if (k % 4 == 0)
                spheres_.push_back(SphereQuad{});
            SphereQuad& quad = spheres_.back();
            const Sphere& s = o.sphere;
            quad.cx[k % 4] = s.center.x;
            quad.cy[k % 4] = s.center.y;
            quad.cz[k % 4] = s.center.z;
            quad.r2[k % 4] = s.radius * s.radius;
            // Below 2⁻¹⁰⁰⁰ r² has lost its relative precision (or is no radius at all): the
            // bound of sphere_candidates does not hold, and the kernels decide.
            if (k < 32 && quad.r2[k % 4] >= 0x1p-1000 && quad.r2[k % 4] <= 0x1p1000)
                cullable_ |= std::uint32_t{1} << k;
            continue;
        }
        const TriangleMesh& mesh = *o.mesh;
        for (std::size_t p = 0; p < mesh.size(); ++p) {
            const Triangle t = mesh.triangle(p);
            prims_.push_back(Primitive{t, triangle_normal(t), TrianglePlane::of(t), i,
                                       static_cast<std::uint32_t>(p), p + 1 == mesh.size()});
        }
    }
    ruled_out_ = ruled_out_in(widest_lanes());
    quads_ = std::min<std::size_t>(spheres_.size(), 8);
}

namespace {

/// W doubles in one vector, and the lanes of their comparisons (0 or −1). GCC takes no
/// vector_size that depends on a template's parameter.
template <int W>
struct VectorOf;
template <>
struct VectorOf<2> {
    using Doubles = double __attribute__((vector_size(16)));
    using Masks = long long __attribute__((vector_size(16)));
};
template <>
struct VectorOf<4> {
    using Doubles = double __attribute__((vector_size(32)));
    using Masks = long long __attribute__((vector_size(32)));
};

/// What the rule needs of the ray, in all W lanes. Made by ruled_out_sse2 and ruled_out_avx,
/// each in its own instruction set: the origin and direction read from the ray into every lane
/// at once (SSE2's movddup, AVX's vbroadcastsd), and d·d formed in the lanes by the scalar's own
/// operations, so the same bits. Copied to scalars first and spread from registers, as until
/// 2026-12-07, each had taken two instructions under AVX (which has no broadcast from a
/// register) and added stack spills: cachegrind of bench_render --smoke counted 5.86M
/// instructions in ruled_out_avx before, 4.81M after.
template <int W>
struct LaneRay {
    typename VectorOf<W>::Doubles ox, oy, oz, dx, dy, dz;
    typename VectorOf<W>::Doubles a;  ///< d·d
    bool behind_ok;                   ///< tmin ≥ 0: roots before the origin are out of range
};

/// d·d in the lanes of a LaneRay whose components are in place, and the range's side.
template <int W>
[[gnu::always_inline]] inline void finish_lane_ray(const Ray& in, LaneRay<W>& r) {
    r.a = r.dx * r.dx + r.dy * r.dy + r.dz * r.dz;
    r.behind_ok = in.tmin >= 0.0;
}

/// The ray in two lanes: each component loaded into both (movddup from memory). Its twin for
/// four lanes, lane_ray4, is compiled for AVX: an AVX intrinsic cannot be inlined into a
/// template shared with SSE2, and written as a loop over the lanes GCC formed d·d in one lane
/// and spread it again, from a register.
[[gnu::always_inline]] inline void lane_ray2(const Ray& in, LaneRay<2>& r) {
    const double* from[6] = {&in.origin.x,    &in.origin.y,    &in.origin.z,
                             &in.direction.x, &in.direction.y, &in.direction.z};
    VectorOf<2>::Doubles* to[6] = {&r.ox, &r.oy, &r.oz, &r.dx, &r.dy, &r.dz};
    for (int k = 0; k < 6; ++k) {
        const __m128d x = _mm_load1_pd(from[k]);
        std::memcpy(to[k], &x, sizeof x);
    }
    finish_lane_ray(in, r);
}

/// The ray in four lanes: each component loaded into all four (vbroadcastsd from memory).
[[gnu::always_inline, gnu::target("avx")]] inline void lane_ray4(const Ray& in, LaneRay<4>& r) {
    const double* from[6] = {&in.origin.x,    &in.origin.y,    &in.origin.z,
                             &in.direction.x, &in.direction.y, &in.direction.z};
    VectorOf<4>::Doubles* to[6] = {&r.ox, &r.oy, &r.oz, &r.dx, &r.dy, &r.dz};
    for (int k = 0; k < 6; ++k) {
        const __m256d x = _mm256_broadcast_sd(from[k]);
        std::memcpy(to[k], &x, sizeof x);
    }
    finish_lane_ray(in, r);
}

/// The rule of SceneScan::sphere_candidates on W spheres side by side (centres cx..cz and r²
/// r2s, W of each), in GCC's vector extension (which clang also compiles): lane k of `miss` is
/// −1 where sphere k is ruled out, else 0. Inlined into each caller, so that its W-wide vectors are
/// compiled for the caller's instruction set (SSE2 for two lanes, AVX for four).
template <int W>
[[gnu::always_inline]] inline void ruled_out_in_lanes(const double* cx, const double* cy,
                                                      const double* cz, const double* r2s,
                                                      const LaneRay<W>& ray,
                                                      typename VectorOf<W>::Masks& miss) {
    using vd = typename VectorOf<W>::Doubles;
    // Loaded by memcpy (no function returns a vector: an AVX vector's ABI differs outside AVX).
    vd x, y, z, r2;
    std::memcpy(&x, cx, sizeof x);
    std::memcpy(&y, cy, sizeof y);
    std::memcpy(&z, cz, sizeof z);
    std::memcpy(&r2, r2s, sizeof r2);
    constexpr double kMax = std::numeric_limits<double>::max();
    const vd& a = ray.a;
    const vd fx = ray.ox - x;
    const vd fy = ray.oy - y;
    const vd fz = ray.oz - z;
    const vd ff = fx * fx + fy * fy + fz * fz;
    const vd beta = fx * ray.dx + fy * ray.dy + fz * ray.dz;
    const vd fa = ff * a;
    // |f × d|² by Lagrange's identity, |f|²|d|² − (f·d)², from the β and |f|²a that the
    // behind test needs anyway (the cross product had cost 13 of the rule's 39 packed
    // multiplications, additions and subtractions, GCC 12 at -O3).
    const vd cc = fa - beta * beta;
    const vd ar2 = a * r2;
    const vd bound = 128.0 * kDoubleUnitRoundoff * (fa + ar2) + 0x1p-900;
    // Lanes are −1 where the line certainly misses (all terms finite, so the comparisons are
    // false on a NaN or an overflow), d·d permitting.
    // Below 2⁻¹⁰²⁰, d·d has lost its relative precision to the subnormal grid, and a·r² (r²
    // up to 2¹⁰⁰⁰) with it: no line is ruled out (a helper's review found a hit at fast with
    // |d| ≈ 3e-162 and r = 1e100 that the test had ruled out).
    miss = (ar2 - cc < -bound) & (bound <= kMax) & (cc <= kMax) & (a >= 0x1p-1020);
    if (ray.behind_ok) {
        // Or where the sphere lies behind: the origin outside it (γ = |f|² − r² > 0) and the
        // ray moving away from its centre (β = f·d > 0). Both roots (−β ± √(β² − aγ))/a are
        // then negative, and the kernels' too: their γ and β keep those signs when each clears
        // its rounding (|f|² and r² within γ₃ and u; β within (γ₃ + u)·|f||d| ≈ 4u·|f||d| of
        // the exact f·d, so β² > 64u²·|f|²a leaves room), and neither forms a root of another
        // sign from them.
        miss |= (ff - r2 > 8.0 * kDoubleUnitRoundoff * (ff + r2)) & (beta > 0.0) &
                (beta * beta > 64.0 * kDoubleUnitRoundoff * kDoubleUnitRoundoff * fa + 0x1p-900) &
                (fa <= kMax) & (ff <= kMax);
    }
}

/// The rule over every quad of spheres (at most 8: 32 bits), two lanes at a time.
std::uint32_t ruled_out_sse2(const detail::SphereQuad* quads, std::size_t n, const Ray& in) {
    LaneRay<2> ray;
    lane_ray2(in, ray);
    std::uint32_t out = 0;
    for (std::size_t j = 0; j < n; ++j) {
        const detail::SphereQuad& q = quads[j];
        VectorOf<2>::Masks lo, hi;
        ruled_out_in_lanes<2>(q.cx, q.cy, q.cz, q.r2, ray, lo);
        ruled_out_in_lanes<2>(q.cx + 2, q.cy + 2, q.cz + 2, q.r2 + 2, ray, hi);
        const auto bits =
            static_cast<std::uint32_t>(_mm_movemask_pd(reinterpret_cast<__m128d>(lo)) |
                                       _mm_movemask_pd(reinterpret_cast<__m128d>(hi)) << 2);
        out |= bits << (4 * j);
    }
    return out;
}

/// The same, four lanes at a time: compiled for AVX (without FMA, and the project builds with
/// -ffp-contract=off, so that every lane rounds as SSE2's does) and called only where the
/// processor has it.
[[gnu::target("avx")]] std::uint32_t ruled_out_avx(const detail::SphereQuad* quads, std::size_t n,
                                                   const Ray& in) {
    LaneRay<4> ray;
    lane_ray4(in, ray);
    std::uint32_t out = 0;
    for (std::size_t j = 0; j < n; ++j) {
        const detail::SphereQuad& q = quads[j];
        VectorOf<4>::Masks miss;
        ruled_out_in_lanes<4>(q.cx, q.cy, q.cz, q.r2, ray, miss);
        out |= static_cast<std::uint32_t>(_mm256_movemask_pd(reinterpret_cast<__m256d>(miss)))
               << (4 * j);
    }
    return out;
}

detail::RuledOut ruled_out_in(SceneScan::Lanes lanes) {
    return lanes == SceneScan::Lanes::four && SceneScan::widest_lanes() == SceneScan::Lanes::four
               ? ruled_out_avx
               : ruled_out_sse2;
}

}  // namespace

SceneScan::Lanes SceneScan::widest_lanes() {
    return cpu_has_avx() ? Lanes::four : Lanes::two;
}

std::uint32_t SceneScan::sphere_candidates(const Ray& ray, Lanes lanes) const {
    // sphere_roots' own plain-double shortcut, on several spheres at a time (vector lanes),
    // before any call: 89% of the sphere tests of the bench's tutorial_like render at exact
    // are lines that miss (counted 2026-12-04: 81 of 92 million), and those calls had been a
    // third of the render (perf). The discriminant a·r² − |f × d|² formed from the rounded
    // f = o − c is within 48u·(|f|²a + a·r²) of the exact one, plus 2⁻⁹⁰⁰ for products that
    // underflow. With |f × d|² as |f|²a − β² (Lagrange's identity), β = f·d (Higham 2002,
    // Lemma 3.1 and §3.1 on the dot products, for the rounded f): |f|² and a are within γ₃ of
    // f·f and d·d, so |f|²a within ~7u of their product; β within γ₃·|f||d|, so β² within
    // ~7u·|f|²|d|² of (f·d)²; the difference rounds by u of the larger term: ~16u·|f|²|d|² in
    // all. The rounding of f itself (u per component) moves |f × d|² by ~2u·|f|²|d|² more, and
    // a·r² is within ~5u of |d|²r² (a within γ₃ of d·d, then r² and the product rounded): within
    // the 48u, although the identity cancels where the line passes near the centre (where
    // nothing is ruled out anyway). A helper's probe measured the rule's discriminant against
    // __float128 with the exact f over 40M rays: at most 8.7u of (|f|²a + a·r²). Beyond 128u of
    // that the exact discriminant is below −80u·a·(|f|² + r²): the double-double discriminant of
    // sphere_roots (a few u² of the same terms) is negative, and so is sphere_roots_fast's r² −
    // |l|² (within ~22u·|f|² + 2u·r² + u·|disc| of Δ/(4a)), so both kernels find no root. A lane
    // with an infinity or NaN anywhere is never ruled out. Four lanes (AVX) against two (SSE2): the
    // tutorial_like render at fast spent 19% of its time here (perf, 2026-12-04), measured in
    // docs/rendering.md.
    if (spheres_.empty())
        return ~std::uint32_t{0};
    return ~(ruled_out_in(lanes)(spheres_.data(), quads_, ray) & cullable_);
}

SphereRoots SceneScan::roots(const Sphere& s, const Ray& ray) const {
    return fast_ ? sphere_roots_fast(s, ray) : sphere_roots(s, ray);
}

std::optional<Hit> SceneScan::triangle(const Triangle& tri, const Ray& ray) const {
    return fast_ ? intersect_triangle_fast(tri, ray, /*want_normal=*/false)
                 : intersect_triangle(tri, ray, /*want_normal=*/false);
}

bool SceneScan::hits_triangle(const Triangle& tri, const Ray& ray) const {
    return fast_ ? intersect_triangle_fast(tri, ray, /*want_normal=*/false).has_value()
                 : decide_triangle(tri, ray).has_value();
}

template <class F>
bool SceneScan::find_sphere(const Ray& ray, F&& f) const {
    for (std::uint32_t bits = sphere_candidates(ray) & sphere_bits_; bits != 0; bits &= bits - 1) {
        if (f(sphere_list_[static_cast<std::size_t>(__builtin_ctz(bits))]))
            return true;
    }
    for (std::size_t k = 32; k < sphere_list_.size(); ++k) {
        if (f(sphere_list_[k]))
            return true;
    }
    return false;
}

namespace {

/// A closest hit being looked for, kept in scalars: whole Hits copied from the kernels' answers
/// had been read back 16 bytes at a time where the kernels wrote them 8 at a time, a
/// store-forwarding stall at each new best (three of them were a sixth of SceneScan::closest's
/// samples in the tutorial_like render, perf annotate with cycles:pp, 2026-12-05).
struct Best {
    double t, t_err = 0.0, u = 0.0, v = 0.0;
    std::uint32_t object = kInvalidId, primitive = kInvalidId;
    bool front_face = true, on_edge = false;
    /// A sphere's root: root_side (its normal is formed for the winner only, after the scan).
    int side = 0;

    /// `closer(h, *this)` for a hit with h.t = t, of `object`, primitive `primitive`.
    bool beaten_by(double ht, std::uint32_t hobject, std::uint32_t hprimitive) const {
        if (ht != t)
            return ht < t;
        if (hobject != object)
            return hobject < object;
        return hprimitive < primitive;
    }
    /// Takes a triangle kernel's answer, field by field.
    void take(const Hit& h, std::uint32_t hobject, std::uint32_t hprimitive) {
        t = h.t;
        t_err = h.t_err;
        u = h.u;
        v = h.v;
        object = hobject;
        primitive = hprimitive;
        front_face = h.front_face;
        on_edge = h.on_edge;
    }
    /// Writes the answer into `out`, field by field (its normal left as it is).
    void put(Hit& out) const {
        out.t = t;
        out.t_err = t_err;
        out.object = object;
        out.primitive = primitive;
        out.u = u;
        out.v = v;
        out.front_face = front_face;
        out.on_edge = on_edge;
    }
};

}  // namespace

std::optional<Hit> SceneScan::closest(const Ray& ray, bool want_normal) const {
    std::optional<Hit> result;
    if (!closest(ray, want_normal, result.emplace()))
        result.reset();
    return result;
}

bool SceneScan::closest(const Ray& ray_in, bool want_normal, Hit& out) const {
    // linear_closest's loop, flattened: the best so far bounds each sphere and each mesh (tmax
    // inclusive, so that an exact tie with another object is still seen and `closer` decides
    // it); a mesh's own triangles narrow its bound further and keep the lower index on an exact
    // tie. The spheres come first, then the meshes (prims_' comment says what the order changes:
    // nothing at exact). One copy of the ray, whose tmax is set to the bound before each test:
    // two Rays copied whole (one per bound, and the second again at each mesh) read back 16
    // bytes at a time what had just been written 8 at a time, store-forwarding stalls that were
    // a fifth of this function's samples in the tutorial_like render (perf annotate).
    Ray r = ray_in;
    Best best{ray_in.tmax}, mesh_best{ray_in.tmax};
    const ScanSphere* sphere_winner = nullptr;
    const Primitive* winner = nullptr;  // a triangle; at most one of the two is set
    // Each candidate sphere: intersect_sphere without the normal (filled below for the
    // winner), its first root in range, primitive 0.
    find_sphere(ray_in, [&](const ScanSphere& sp) {
        r.tmax = best.t;
        const SphereRoots roots_of = roots(sp.sphere, r);
        const int k = first_root_in_range(roots_of, r);
        if (k >= 0 && (!sphere_winner || best.beaten_by(roots_of.t[k], sp.object, 0))) {
            best.t = roots_of.t[k];
            best.t_err = roots_of.t_err;
            best.u = best.v = 0.0;
            best.object = sp.object;
            best.primitive = 0;
            best.front_face = true;
            best.on_edge = false;
            best.side = root_side(roots_of, k);
            sphere_winner = &sp;
        }
        return false;  // every candidate is tested
    });
    const Primitive* mesh_winner = nullptr;
    bool new_object = true;
    for (const Primitive& p : prims_) {
        if (new_object) {
            mesh_best.t = best.t;
            mesh_winner = nullptr;
        }
        // A plane left behind, or crossed beyond the best so far: a miss, without Woop's test.
        r.tmax = mesh_best.t;
        if (!left_behind<true>(p.plane, r, p.tri.a)) {
            const std::optional<Hit> h = triangle(p.tri, r);
            if (h && (!mesh_winner || h->t < mesh_best.t)) {
                mesh_best.take(*h, p.object, p.index);
                mesh_winner = &p;
            }
        }
        new_object = p.last_of_object;
        if (p.last_of_object && mesh_winner &&
            ((!winner && !sphere_winner) ||
             best.beaten_by(mesh_best.t, mesh_best.object, mesh_best.primitive))) {
            best = mesh_best;
            winner = mesh_winner;
            sphere_winner = nullptr;
        }
    }
    if (!winner && !sphere_winner)
        return false;
    // Written into the caller's Hit, for the stall that a Hit made here and copied out had
    // (Best's comment).
    best.put(out);
    if (want_normal) {
        if (sphere_winner)
            sphere_normal(sphere_winner->sphere, ray_in, out.t, best.side, out);
        else
            out.normal = winner->normal;
    }
    return true;
}

bool SceneScan::any(const Ray& ray) const {
    if (find_sphere(ray, [&](const ScanSphere& sp) {
            return first_root_in_range(roots(sp.sphere, ray), ray) >= 0;
        }))
        return true;
    for (const Primitive& p : prims_) {
        if (!left_behind<true>(p.plane, ray, p.tri.a) && hits_triangle(p.tri, ray))
            return true;
    }
    return false;
}

}  // namespace raycastd::engine
