#include "engine/accel/embree/packets.h"

#include <algorithm>

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

bool fast_packet(const Impl& a, RTCScene scene, const Ray* rays, std::size_t m, bool want_normal,
                 Hit* out) {
    alignas(64) RTCRayHit16 rh;
    alignas(64) int valid[kLanes];
    for (std::size_t k = 0; k < kLanes; ++k) {
        // Lanes past m repeat the last ray, switched off, so that the coherence test below
        // needs no mask.
        FloatRay f;
        if (!unclipped_float_ray(a, rays[std::min(k, m - 1)], f))
            return false;
        fill_lane(rh.ray, k, f, static_cast<unsigned>(k));
        rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        valid[k] = k < m ? -1 : 0;
    }
    const bool together = coherent(
        kLanes,
        [&rh](std::size_t k) {
            return Vec3f{rh.ray.dir_x[k], rh.ray.dir_y[k], rh.ray.dir_z[k]};
        },
        [&rh](std::size_t k) {
            return Vec3f{rh.ray.org_x[k], rh.ray.org_y[k], rh.ray.org_z[k]};
        },
        to_float(0.0025 * a.float_scale * a.float_scale));  // may exceed FLT_MAX
    RTCIntersectContext ctx = flagged_context(together);
    rtcIntersect16(valid, scene, &ctx, &rh);
    for (std::size_t k = 0; k < m; ++k) {
        if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) {
            out[k] = Hit{};  // fast takes a float miss as it is
            continue;
        }
        fast_hit(a, rays[k], 0.0, 1.0, native_hit(rh, k), want_normal, out[k]);
    }
    return true;
}

}  // namespace raycastd::engine::embree
