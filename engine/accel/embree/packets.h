#pragma once
// Embree's 16-wide packets for a batch's closest and any queries: the rays of a group are
// traced together by rtcIntersect16 / rtcOccluded16, flagged coherent (camera rays) or not.
// Packets carry only Embree's own triangles: user geometry (spheres) and the exact BVH are
// traced one ray at a time, so a packet's lanes are never handed to our callbacks.
//
//   fast_packet     fast's common case: every lane takes the unclipped float ray, so the lanes
//   fast_any_packet are filled straight from the double rays and answered straight from
//                   Embree's hits;
//   closest_packet  any float set-up (fast's clipped rays, refined's), each lane with its own
//   any_packet      RayContext (the packet's context points to them, for refined's hit filter);
//                   the caller says how to prepare a lane and how to answer one.
//
// One coherence test decides the flag, evaluated in double on the rays (general packets) or in
// float on the filled lanes (fast_packet), from the same template.

#include <cstddef>
#include <cstdint>
#include <optional>

#include <embree3/rtcore.h>

#include "engine/accel/embree/fat_triangles.h"
#include "engine/accel/embree/float_ray.h"
#include "engine/accel/embree/impl.h"

namespace raycastd::engine::embree {

/// Rays per packet.
constexpr std::size_t kLanes = 16;

/// Whether rays 0..n are coherent enough for a packet flagged coherent: directions within ~10°
/// of the first (cos² ≥ 0.97, without square roots: d·d₀ > 0 and (d·d₀)² ≥ 0.97·|d|²·|d₀|²) and
/// origins within √max_spread2 of the first (5% of the scene: 0.0025·scale²) — camera rays, not
/// random rays. Flagged packets win 2.6× on camera rays. `dir(k)` and `org(k)` give ray k's
/// direction and origin as Vec3<T>: the double rays, or the float lanes of a filled packet. No
/// early exit, so that the float form vectorises.
template <class T, class Dir, class Org>
bool coherent(std::size_t n, const Dir& dir, const Org& org, T max_spread2) {
    const Vec3<T> d0 = dir(0);
    const Vec3<T> o0 = org(0);
    const T d0d0 = dot(d0, d0);
    bool incoherent = false;
    for (std::size_t k = 1; k < n; ++k) {
        const Vec3<T> d = dir(k);
        const T c = dot(d, d0);
        const Vec3<T> o = org(k) - o0;
        // Branch-free: three |= rather than one a | b | c, which clang's
        // -Wbitwise-instead-of-logical rejects on bool operands.
        incoherent |= c <= T(0);
        incoherent |= c * c < T(0.97) * dot(d, d) * d0d0;
        incoherent |= dot(o, o) > max_spread2;
    }
    return !incoherent;
}

/// The context of a packet of rays[0..m): flagged coherent when they are (coherent() in double,
/// scene_scale = Impl::float_scale).
RTCIntersectContext packet_context(const Ray* rays, std::size_t m, double scene_scale);

/// How fast_packet fills its lanes from the double rays: one ray at a time, or four at a time
/// in AVX's registers where the processor has it (the same lanes: packets.cpp).
enum class FastLanes { one_by_one, avx };
/// The widest this processor runs: avx where it has AVX.
FastLanes widest_fast_lanes();

/// fast_packet's and fast_any_packet's lanes: lane k < m from rays[k]'s unclipped float ray
/// (unclipped_float_ray), lanes past m repeating the last ray, switched off (valid 0), so that the
/// coherence test needs no mask. Returns the packet's context, flagged by that test in float, or
/// nothing (with the lanes partly written) when some ray needs prepare_ray. `how`: avx is taken
/// as one_by_one where widest_fast_lanes() says the processor has no AVX. Public for tests.
std::optional<RTCIntersectContext> fill_fast_lanes(const Impl& a, const Ray* rays, std::size_t m,
                                                   RTCRay16& r16, int* valid,
                                                   FastLanes how = FastLanes::avx);

/// fast_packet's answers from Embree's: out[k] for k < m is fast_hit of lane k (t = its float t
/// over Impl::unit, clamped into [tmin, tmax], with its t_err and, if `want_normal`, the unit
/// normal), or Hit{} where the lane found nothing. `how` as in fill_fast_lanes (the same Hits
/// either way). Public for tests.
void fast_packet_answers(const Impl& a, const Ray* rays, std::size_t m, const RTCRayHit16& rh,
                         bool want_normal, Hit* out, FastLanes how = FastLanes::avx);

/// fast's packet of m (4 ≤ m ≤ 16) rays of a triangle-only scene on `scene` when every one of
/// them takes the unclipped float ray (unclipped_float_ray), i.e. almost always: t needs no
/// shift or rescale, so the lanes are filled straight from the double rays and the answers
/// (fast_hit, a miss as Hit{}) written straight from Embree's, with no per-lane RayContext, no
/// coherence test in double and no std::optional<Hit> in between. That per-ray work was 40% of
/// a camera-ray batch on bench_intersect's workload B (perf: closest_range,
/// prepare_native_ray, finish_native, coherent), against 12% in raw Embree's own loop. False,
/// with nothing written, when some ray needs prepare_ray.
bool fast_packet(const Impl& a, RTCScene scene, const Ray* rays, std::size_t m, bool want_normal,
                 Hit* out);

/// fast_packet's `any`: the occlusion packet of rays[0..m) (4 ≤ m ≤ 16, a triangle-only scene)
/// on `scene` with lanes filled straight from the double rays, out[k] = 1 where Embree's float
/// answer is a hit, else 0. Renders trace their shadow rays through it: the general any_packet's 16
/// RayContexts and coherence test in double had been 9% of a Duck render (perf). False, with
/// nothing written, when some ray needs prepare_ray. `scene` is fast's own BVH, which has no
/// hit filter (the packet's context is a plain one).
bool fast_any_packet(const Impl& a, RTCScene scene, const Ray* rays, std::size_t m,
                     std::uint8_t* out);

/// Lane k of a packet as fill_lanes makes it.
template <class Prepare>
void prepare_lane(const Impl& a, const Ray* rays, std::size_t m, Prepare& prepare, std::size_t k,
                  RayContext* lanes, RTCRay16& r16, int* valid) {
    FloatRay f;
    lanes[k].accel = &a;
    const bool on = k < m && prepare(rays[k], lanes[k], f);
    if (!on)
        f.tfar = -1.0f;
    fill_lane(r16, k, f, static_cast<unsigned>(k));
    valid[k] = on ? -1 : 0;
}

/// Lanes 0..16 of a packet from rays[0..m): lane k < m is on (valid −1) when prepare(ray,
/// lanes[k], float_ray) set it up; lanes past m, and rays whose segment misses the bounds, are
/// off (valid 0, tfar −1).
template <class Prepare>
void fill_lanes(const Impl& a, const Ray* rays, std::size_t m, Prepare& prepare, RayContext* lanes,
                RTCRay16& r16, int* valid) {
    for (std::size_t k = 0; k < kLanes; ++k)
        prepare_lane(a, rays, m, prepare, k, lanes, r16, valid);
}

/// Lanes as prepare_ray(RayStart::backed_off, RayFrame::world) sets them up (refined's packets,
/// exact's batches), with RayContext::want_normal = `want_normal` (as
/// prepare_refined_closest_ray and exact_closest set it first), for the rays of rays[0..m) it
/// can set up four at a time in AVX's registers (the processor must have it): the same
/// operations as prepare_ray's, so the same bits. Returns the lanes it left (bit k): a ray that
/// takes another branch of prepare_ray (a direction with a zero component, an origin far from
/// the scene, a length beyond 2^±500, a start point it leaves unplaced), and the lanes past m.
/// The lanes it leaves may hold anything (valid[] unwritten, a copy of the last ray's lane past
/// m): the caller fills every one of them (fill_backed_off_lanes) or reads none (exact's
/// batches read only the lanes it set up).
unsigned backed_off_lanes_avx(const Impl& a, const Ray* rays, std::size_t m, bool want_normal,
                              RayContext* lanes, RTCRay16& r16, int* valid);

/// float_up (float_bounds.h) of in[0..4) into out[0..4), as backed_off_lanes_avx forms tfar, four
/// at a time; for its test. The processor must have AVX.
void float_up_four_avx(const double* in, float* out);

/// fill_lanes(prepare) where `prepare` is prepare_ray as backed_off_lanes_avx takes it (refined's
/// packets): the lanes backed_off_lanes_avx sets up where the processor has AVX (and `how`
/// allows), `prepare` the others. One ray at a time, prepare_ray and its slab test were a sixth
/// of a refined batch of camera rays on workload B (perf: prepare_ray, clip_to_bounds, their
/// square roots and divisions waiting on each other).
template <class Prepare>
void fill_backed_off_lanes(const Impl& a, const Ray* rays, std::size_t m, bool want_normal,
                           Prepare& prepare, RayContext* lanes, RTCRay16& r16, int* valid,
                           FastLanes how = FastLanes::avx) {
    unsigned left = (1u << kLanes) - 1;
    if (how == FastLanes::avx && widest_fast_lanes() == FastLanes::avx)
        left = backed_off_lanes_avx(a, rays, m, want_normal, lanes, r16, valid);
    for (std::size_t k = 0; k < kLanes; ++k) {
        if (left >> k & 1)
            prepare_lane(a, rays, m, prepare, k, lanes, r16, valid);
    }
}

/// Closest hits of rays[0..m) (4 ≤ m ≤ 16, a triangle-only scene) as one packet on `scene`:
/// lanes from fill(lanes, r16, valid) (fill_lanes, fill_backed_off_lanes); out[k] is answer(k,
/// context, native_hit) as a Hit (an empty optional: a miss), or Hit{} where the lane is off (the
/// ray's segment misses the bounds).
/// With `defer` (refined's packets), a packet that is not flagged coherent lets the hit filter
/// defer a lane's first decision (RayContext::defer), and the deferred ones are settled after the
/// traversal (settle_pending_lanes); a lane then marked RayContext::retrace is the answer's to
/// trace again, and its native_hit means nothing (Embree committed what was accepted undecided).
/// Such a lane's tfar also differed from what deciding as it went would have left, which may
/// change the order in which Embree offers the packet's other lanes their candidates; their
/// answers depend on that order only where refined's already do (a back face after a rejection
/// behind it, coplanar faces of two objects: docs/numerics.md).
/// Random rays gain: on workload B, whose triangles are far beyond the cache, each decision had
/// waited on two dependent misses (the index row, then the corners) inside the traversal.
/// Camera rays share their triangles, which are in cache; their packets decide as they go.
template <class Fill, class Answer>
void closest_packet_filled(const Impl& a, RTCScene scene, const Ray* rays, std::size_t m,
                           Fill&& fill, Answer&& answer, Hit* out, bool defer = false) {
    RayContext lanes[kLanes];
    alignas(64) RTCRayHit16 rh;
    alignas(64) int valid[kLanes];
    fill(lanes, rh.ray, valid);
    for (std::size_t k = 0; k < kLanes; ++k)
        rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
    // The lanes travel in the context: refined's hit filter finds a lane's double ray and
    // keeps its decision there (fat_triangles.cpp).
    RayContext pc(a);
    pc.rtc = packet_context(rays, m, a.float_scale);
    pc.lanes = lanes;
    pc.defer = defer && !(pc.rtc.flags & RTC_INTERSECT_CONTEXT_FLAG_COHERENT);
    rtcIntersect16(valid, scene, &pc.rtc, &rh);
    if (pc.defer)
        settle_pending_lanes(lanes, m);
    for (std::size_t k = 0; k < m; ++k) {
        if (!valid[k]) {
            out[k] = Hit{};  // the segment misses the scene's bounds: nothing can be hit
            continue;
        }
        const std::optional<Hit> h = answer(k, lanes[k], native_hit(rh, k));
        out[k] = h ? *h : Hit{};
    }
}

/// closest_packet_filled with the lanes from prepare(ray, context, float_ray) (fill_lanes).
template <class Prepare, class Answer>
void closest_packet(const Impl& a, RTCScene scene, const Ray* rays, std::size_t m,
                    Prepare&& prepare, Answer&& answer, Hit* out) {
    closest_packet_filled(
        a, scene, rays, m,
        [&](RayContext* lanes, RTCRay16& r16, int* valid) {
            fill_lanes(a, rays, m, prepare, lanes, r16, valid);
        },
        answer, out);
}

/// `any` answers (1: blocked, 0: free) of rays[0..m) (4 ≤ m ≤ 16, a triangle-only scene) as one
/// occlusion packet on `scene`, lanes as in closest_packet_filled; a lane that met the bounds but
/// found nothing is answered by confirm_miss(k, its context).
template <class Fill, class ConfirmMiss>
void any_packet_filled(const Impl& a, RTCScene scene, const Ray* rays, std::size_t m, Fill&& fill,
                       ConfirmMiss&& confirm_miss, std::uint8_t* out) {
    RayContext lanes[kLanes];
    alignas(64) RTCRay16 r16;
    alignas(64) int valid[kLanes];
    fill(lanes, r16, valid);
    RayContext pc(a);
    pc.rtc = packet_context(rays, m, a.float_scale);
    pc.lanes = lanes;
    rtcOccluded16(valid, scene, &pc.rtc, &r16);
    for (std::size_t k = 0; k < m; ++k) {
        bool hit = valid[k] && occluded_tfar(r16.tfar[k]);
        if (valid[k] && !hit)
            hit = confirm_miss(k, lanes[k]);
        out[k] = hit ? 1 : 0;
    }
}

/// any_packet_filled with the lanes from prepare(ray, context, float_ray) (fill_lanes).
template <class Prepare, class ConfirmMiss>
void any_packet(const Impl& a, RTCScene scene, const Ray* rays, std::size_t m, Prepare&& prepare,
                ConfirmMiss&& confirm_miss, std::uint8_t* out) {
    any_packet_filled(
        a, scene, rays, m,
        [&](RayContext* lanes, RTCRay16& r16, int* valid) {
            fill_lanes(a, rays, m, prepare, lanes, r16, valid);
        },
        confirm_miss, out);
}

}  // namespace raycastd::engine::embree
