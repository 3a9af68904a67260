#pragma once
// Robust origins for secondary rays (pbrt-v4 §6.8.6, "Robust Spawned Ray Origins").
//
// A hit point p = o + t·d is only known to within an error box: |d|·t_err from the
// intersection's t, plus the rounding of the product and the sum (γ₂·(|o| + |t·d|) per
// component, Higham 2002 Lemma 3.1). A ray spawned from p itself can hit the surface it leaves
// at t ≈ 0 ("acne"). Moving the origin along the geometric normal, to the side the new ray goes,
// by the projection of that box on the normal, d = Σ|nᵢ|·errᵢ, puts it outside the box and so
// strictly on the right side of the true surface; each component is then rounded away from p so
// that the rounding of the move cannot undo it.
//
// When the tracer answering the spawned ray decides in single precision (Embree's float
// traversal in the fast and refined paths), the surface it sees differs from the double one by
// its own float rounding, so the box must also hold that: the tracer's FloatFrame
// (Tracer::float_frame, math/float_frame.h) says how large it is.

#include <cmath>
#include <cstdint>
#include <cstring>

#include "engine/math/float_bounds.h"
#include "engine/math/float_frame.h"
#include "engine/math/ray.h"

namespace raycastd::engine {

/// Per-component bound on |p − p_exact| for p = ray.at(hit.t), including the rounding of the
/// float tracer of `frame` (none when frame.scale is 0: a tracer that decides in double).
Vec3d hit_point_error(const Ray& ray, const Hit& hit, const FloatFrame& frame);

/// What a float tracer of `frame` adds to the error of a point p it spawns rays from (its
/// rounding of the origin and of its own copy of the surface); zero when frame.scale is 0.
/// hit_point_error includes it; a point taken on the surface (query/intersect.h,
/// surface_point) adds it to its own bound.
Vec3d float_tracer_error(const Vec3d& p, const FloatFrame& frame);

namespace detail {

/// moved_away's step where the sum is ±0, ±inf or NaN. Out of line and cold: inlined, GCC
/// threaded its comparisons of the offset with zero into moved_away's common path and made
/// branches of it again.
[[gnu::noinline, gnu::cold]] inline double moved_away_rarely(double po, double offset) {
    return offset > 0.0 ? next_up(po) : offset < 0.0 ? next_down(po) : po;
}

/// p + offset rounded once more away from p, so that the addition cannot land back inside the
/// error box: next_up(p + offset) for a positive offset, next_down for a negative one, the
/// sum itself for a zero one. Where p + offset is finite and not zero (every spawned origin but
/// the rarest), that step is one unit of the bits' magnitude, up when the sum and the offset
/// have one sign and down otherwise (next_up's and next_down's own steps), or none: chosen
/// without a branch. The offset's sign follows the normal's components, which a renderer's
/// rays leave to chance, and a floor's normal has two zero components: the branches on them
/// had been mispredicted (cachegrind's branch simulation of bench_render --smoke: 14,925 in
/// offset_ray_origin with them, 28,399 with a branch on a zero offset alone, 117 without; and
/// offset_ray_origin 100 times over 65,536 origins, half off a floor and half off random
/// normals: 148–151 ms with the branches, 71–84 ms without, five alternating runs).
inline double moved_away(double p, double offset) {
    const double po = p + offset;
    std::uint64_t bits, offset_bits;
    std::memcpy(&bits, &po, sizeof bits);
    std::memcpy(&offset_bits, &offset, sizeof offset_bits);
    // One comparison for a sum of ±0 (magnitude 0 wraps to the top) or ±inf or NaN (magnitude
    // from 0x7ff0…0 on): next_up and next_down decide those.
    constexpr std::uint64_t kSign = std::uint64_t{1} << 63;
    constexpr std::uint64_t kInfBits = 0x7ff0000000000000ull;
    if ((bits & ~kSign) - 1 >= kInfBits - 1)
        return moved_away_rarely(po, offset);
    // In integer arithmetic alone, which GCC leaves as it is (a comparison of the offset with
    // zero, even into a 0 or 1, it turned back into branches): `moves` is 1 for an offset other
    // than ±0 (its magnitude's bits, shifted out of the sign, or their negation has the top bit
    // set) and 0 for ±0 (a NaN offset has made po NaN above); `differ` is 1 where the signs of
    // the sum and the offset differ, for a step of −1, else +1.
    const std::uint64_t magnitude = offset_bits << 1;
    const std::uint64_t moves = (magnitude | (0 - magnitude)) >> 63;
    const std::uint64_t differ = (bits ^ offset_bits) >> 63;
    bits = bits + moves - 2 * (moves & differ);
    double out;
    std::memcpy(&out, &bits, sizeof out);
    return out;
}

}  // namespace detail

// The three below are inline: a renderer spawns millions of rays, and a Ray returned from a
// call in another file was written in 8-byte pieces and read back in 16-byte ones by the
// caller copying it into its batch (those copies were the hottest stores of shade_batch on the
// Duck, perf annotate); inline, a Duck render took 1–2% less time in paired runs.

/// The origin for a ray leaving p (error `p_err`) in direction `w`: p moved along the unit
/// geometric normal `n`, to the side of `w`, past the error box, rounded away from p.
inline Vec3d offset_ray_origin(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& w) {
    const double d = dot(abs(n), p_err);
    Vec3d offset = n * d;
    if (dot(w, n) < 0.0)
        offset = -offset;
    // Component by component, not through an indexed loop over a Vec3d: GCC kept that one in
    // memory, and reading it back whole after writing one component stalled store forwarding
    // (a third of spawn_ray's samples on the Duck, perf annotate).
    return {detail::moved_away(p.x, offset.x), detail::moved_away(p.y, offset.y),
            detail::moved_away(p.z, offset.z)};
}

/// A ray leaving the hit in direction `w` (tmin 0, tmax ∞), written into `r`. A batch writes
/// its rays in place this way: built on the stack and copied in, each was written in 8-byte
/// pieces and read back in 16-byte ones (shade_batch's hottest stores, perf annotate).
inline void spawn_ray(Ray& r, const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& w) {
    r.origin = offset_ray_origin(p, p_err, n, w);
    r.direction = w;
    r.tmin = 0.0;
    r.tmax = kInfinity;
}

inline Ray spawn_ray(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& w) {
    Ray r;
    spawn_ray(r, p, p_err, n, w);
    return r;
}

/// A shadow ray from the hit towards the point `target` (a point light), written into `r`: the
/// direction is target − origin and tmax is just below 1, so the segment stops short of the
/// light itself.
inline void spawn_ray_to(Ray& r, const Vec3d& p, const Vec3d& p_err, const Vec3d& n,
                         const Vec3d& target) {
    r.origin = offset_ray_origin(p, p_err, n, target - p);
    r.direction = target - r.origin;
    r.tmin = 0.0;
    // Stop short of the light: something exactly at the light's position does not shadow it.
    r.tmax = 1.0 - gamma(4);
}

inline Ray spawn_ray_to(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& target) {
    Ray r;
    spawn_ray_to(r, p, p_err, n, target);
    return r;
}

}  // namespace raycastd::engine
