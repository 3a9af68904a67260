#include "engine/accel/embree/packets.h"

#include <algorithm>
#include <optional>

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
    return flagged_context(coherent(
        m, [rays](std::size_t k) { return rays[k].direction; },
        [rays](std::size_t k) { return rays[k].origin; }, 0.0025 * scene_scale * scene_scale));
}

namespace {

/// fast_packet's and fast_any_packet's lanes: lane k < m from rays[k]'s unclipped float ray,
/// lanes past m repeating the last ray, switched off, so that the coherence test needs no mask.
/// Returns the packet's context, flagged by that test in float, or nothing (with the lanes
/// partly written) when some ray needs prepare_ray.
std::optional<RTCIntersectContext> fill_fast_lanes(const Impl& a, const Ray* rays, std::size_t m,
                                                   RTCRay16& r16, int* valid) {
    for (std::size_t k = 0; k < kLanes; ++k) {
        FloatRay f;
        if (!unclipped_float_ray(a, rays[std::min(k, m - 1)], f))
            return std::nullopt;
        fill_lane(r16, k, f, static_cast<unsigned>(k));
        valid[k] = k < m ? -1 : 0;
    }
    const bool together = coherent(
        kLanes,
        [&r16](std::size_t k) {
            return Vec3f{r16.dir_x[k], r16.dir_y[k], r16.dir_z[k]};
        },
        [&r16](std::size_t k) {
            return Vec3f{r16.org_x[k], r16.org_y[k], r16.org_z[k]};
        },
        to_float(0.0025 * (a.float_scale * a.unit) * (a.float_scale * a.unit)));
    return flagged_context(together);
}

}  // namespace

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
    for (std::size_t k = 0; k < m; ++k) {
        if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) {
            out[k] = Hit{};  // fast takes a float miss as it is
            continue;
        }
        fast_hit(a, rays[k], 0.0, a.unit, native_hit(rh, k), want_normal, out[k]);
    }
    return true;
}

bool fast_any_packet(const Impl& a, RTCScene scene, const Ray* rays, std::size_t m, Hit* out) {
    alignas(64) RTCRay16 r16;
    alignas(64) int valid[kLanes];
    std::optional<RTCIntersectContext> ctx = fill_fast_lanes(a, rays, m, r16, valid);
    if (!ctx)
        return false;
    rtcOccluded16(valid, scene, &*ctx, &r16);
    for (std::size_t k = 0; k < m; ++k)
        out[k] = any_answer(occluded_tfar(r16.tfar[k]));  // fast takes a float miss as it is
    return true;
}

}  // namespace raycastd::engine::embree
