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

// Everything below is inline: a renderer spawns millions of rays, and a Ray returned from a
// call in another file was written in 8-byte pieces and read back in 16-byte ones by the
// caller copying it into its batch (those copies were the hottest stores of shade_batch on the
// Duck, perf annotate); inline, a Duck render took 1–2% less time in paired runs.

/// Which side of the unit geometric normal `n` a ray leaving in direction `w` starts on:
/// behind it (true) where w points against n.
inline bool leaves_behind(const Vec3d& n, const Vec3d& w) {
    return dot(w, n) < 0.0;
}

/// offset_ray_origin for a ray on the side `behind` says (leaves_behind): it depends on w only
/// through that side, so that a surface point that sends several rays (a shadow ray to each
/// light, a reflected ray) forms each side's origin once (Whitted's Surface keeps them).
inline Vec3d offset_ray_origin_on(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, bool behind) {
    const double d = dot(abs(n), p_err);
    Vec3d offset = n * d;
    if (behind)
        offset = -offset;
    // Component by component, not through an indexed loop over a Vec3d: GCC kept that one in
    // memory, and reading it back whole after writing one component stalled store forwarding
    // (a third of spawn_ray's samples on the Duck, perf annotate).
    return {detail::moved_away(p.x, offset.x), detail::moved_away(p.y, offset.y),
            detail::moved_away(p.z, offset.z)};
}

/// The origin for a ray leaving p (error `p_err`) in direction `w`: p moved along the unit
/// geometric normal `n`, to the side of `w`, past the error box, rounded away from p.
inline Vec3d offset_ray_origin(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& w) {
    return offset_ray_origin_on(p, p_err, n, leaves_behind(n, w));
}

/// offset_ray_origin's two answers for one point, each formed by the first ray that needs it:
/// a shaded point sends a shadow ray to each facing light and a reflected ray, most of them from
/// the side the normal points to, and each had formed the same origin again (the spawns' lines
/// were 8% of a Duck render's instructions: callgrind of bench_render, 2026-12-08). Every call
/// must pass the same p, p_err and n (Whitted's Surface keeps one for its point).
class SpawnOrigins {
  public:
    /// Nothing formed. The origins themselves are left unset: set to zero with every shaded
    /// point, as Vec3d's initialisers would, the stores took back 26M of the 38M instructions
    /// the cache saved in a 256×192 Duck render (callgrind).
    SpawnOrigins() : formed_(0) {}

    /// offset_ray_origin(p, p_err, n, w), bit for bit.
    Vec3d towards(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& w) {
        const unsigned side = leaves_behind(n, w) ? 1u : 0u;
        double* const at = at_[side];
        if (!(formed_ >> side & 1u)) {
            const Vec3d o = offset_ray_origin_on(p, p_err, n, side != 0);
            at[0] = o.x;
            at[1] = o.y;
            at[2] = o.z;
            formed_ |= 1u << side;
        }
        return {at[0], at[1], at[2]};
    }

  private:
    double at_[2][3];  ///< in front of n [0], behind it [1]; set where formed_ has the bit
    unsigned formed_;
};

/// The ray of spawn_ray from its origin `o` (offset_ray_origin's for w), written into `r`: a
/// batch writes its rays in place (Whitted::spawn, with its point's SpawnOrigins). Built on the
/// stack and copied in, each was written in 8-byte pieces and read back in 16-byte ones
/// (shade_batch's hottest stores, perf annotate).
inline void spawn_ray_from(Ray& r, const Vec3d& o, const Vec3d& w) {
    r.origin = o;
    r.direction = w;
    r.tmin = 0.0;
    r.tmax = kInfinity;
}

/// A ray leaving the hit in direction `w` (tmin 0, tmax ∞), written into `r`.
inline void spawn_ray(Ray& r, const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& w) {
    spawn_ray_from(r, offset_ray_origin(p, p_err, n, w), w);
}

inline Ray spawn_ray(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& w) {
    Ray r;
    spawn_ray(r, p, p_err, n, w);
    return r;
}

/// The shadow ray of spawn_ray_to from its origin `o` (offset_ray_origin's for target − p).
inline void spawn_ray_to_from(Ray& r, const Vec3d& o, const Vec3d& target) {
    r.origin = o;
    r.direction = target - o;
    r.tmin = 0.0;
    // Stop short of the light: something exactly at the light's position does not shadow it.
    r.tmax = 1.0 - gamma(4);
}

/// A shadow ray from the hit towards the point `target` (a point light), written into `r`: the
/// direction is target − origin and tmax is just below 1, so the segment stops short of the
/// light itself.
inline void spawn_ray_to(Ray& r, const Vec3d& p, const Vec3d& p_err, const Vec3d& n,
                         const Vec3d& target) {
    spawn_ray_to_from(r, offset_ray_origin(p, p_err, n, target - p), target);
}

inline Ray spawn_ray_to(const Vec3d& p, const Vec3d& p_err, const Vec3d& n, const Vec3d& target) {
    Ray r;
    spawn_ray_to(r, p, p_err, n, target);
    return r;
}

}  // namespace raycastd::engine
