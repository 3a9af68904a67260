#include "bench/raw_embree.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace raycastd::bench {

namespace {

constexpr unsigned kFullMask = 0xFFFFFFFFu;
constexpr std::uint32_t kMiss = 0xFFFFFFFFu;
constexpr std::size_t kRayGrain = 1024;   ///< rays per TBB task for single-ray calls
constexpr std::size_t kPacketGrain = 64;  ///< packets per TBB task

/// Keeps the first error only: later ones are usually consequences of it.
void record_error(void* user, RTCError code, const char* message) {
    auto* error = static_cast<std::string*>(user);
    if (error->empty()) {
        *error = "embree error " + std::to_string(static_cast<int>(code)) + ": " +
                 (message ? message : "");
    }
}

RTCBuildQuality embree_quality(BuildQuality q) {
    switch (q) {
        case BuildQuality::low:
            return RTC_BUILD_QUALITY_LOW;
        case BuildQuality::medium:
            return RTC_BUILD_QUALITY_MEDIUM;
        case BuildQuality::high:
            return RTC_BUILD_QUALITY_HIGH;
    }
    return RTC_BUILD_QUALITY_MEDIUM;
}

RTCGeometry triangle_geometry(RTCDevice device, const Workload& w) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), w.positions.size()));
    auto* i = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), w.triangles.size()));
    if (v && i) {
        std::copy(&w.positions[0][0], &w.positions[0][0] + 3 * w.positions.size(), v);
        std::copy(&w.triangles[0][0], &w.triangles[0][0] + 3 * w.triangles.size(), i);
    }
    return g;
}

/// Embree's own ray-oriented discs/spheres: SPHERE_POINT takes x, y, z, radius per point.
RTCGeometry sphere_geometry(RTCDevice device, const Workload& w) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), w.spheres.size()));
    if (v)
        std::copy(&w.spheres[0][0], &w.spheres[0][0] + 4 * w.spheres.size(), v);
    return g;
}

void set_ray(RTCRay& ray, const RayRecord& r) {
    ray.org_x = r.ox;
    ray.org_y = r.oy;
    ray.org_z = r.oz;
    ray.dir_x = r.dx;
    ray.dir_y = r.dy;
    ray.dir_z = r.dz;
    ray.tnear = r.tmin;
    ray.tfar = r.tmax;
    ray.time = 0.0f;
    ray.mask = kFullMask;
    ray.id = 0;
    ray.flags = 0;
}

/// Fills lane `k` of a 16-wide packet from r (the SOA layout of RTCRay16).
void set_lane(RTCRay16& ray, int k, const RayRecord& r) {
    ray.org_x[k] = r.ox;
    ray.org_y[k] = r.oy;
    ray.org_z[k] = r.oz;
    ray.dir_x[k] = r.dx;
    ray.dir_y[k] = r.dy;
    ray.dir_z[k] = r.dz;
    ray.tnear[k] = r.tmin;
    ray.tfar[k] = r.tmax;
    ray.time[k] = 0.0f;
    ray.mask[k] = kFullMask;
    ray.id[k] = 0;
    ray.flags[k] = 0;
}

}  // namespace

void RawHits::prepare(std::size_t n) {
    t.assign(n, 0.0f);
    object.assign(n, 0);
    primitive.assign(n, 0);
}

std::size_t RawHits::hit_count() const {
    return static_cast<std::size_t>(
        std::count_if(object.begin(), object.end(), [](std::uint32_t o) { return o != kMiss; }));
}

const char* to_string(BuildQuality q) {
    switch (q) {
        case BuildQuality::low:
            return "low";
        case BuildQuality::medium:
            return "medium";
        case BuildQuality::high:
            return "high";
    }
    return "medium";
}

std::string RawEmbree::version() {
    return RTC_VERSION_STRING;
}

std::unique_ptr<RawEmbree> RawEmbree::build(const Workload& w, BuildQuality quality, bool robust,
                                            std::string& error) {
    std::unique_ptr<RawEmbree> e(new RawEmbree);
    e->spheres_ = !w.spheres.empty();
    e->device_ = rtcNewDevice(nullptr);
    if (!e->device_) {
        error =
            "rtcNewDevice failed: " + std::to_string(static_cast<int>(rtcGetDeviceError(nullptr)));
        return nullptr;
    }
    rtcSetDeviceErrorFunction(e->device_, record_error, &e->error_);
    e->scene_ = rtcNewScene(e->device_);
    rtcSetSceneBuildQuality(e->scene_, embree_quality(quality));
    rtcSetSceneFlags(e->scene_, robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
    RTCGeometry g = e->spheres_ ? sphere_geometry(e->device_, w) : triangle_geometry(e->device_, w);
    rtcSetGeometryBuildQuality(g, embree_quality(quality));
    rtcCommitGeometry(g);
    rtcAttachGeometry(e->scene_, g);
    rtcReleaseGeometry(g);

    const auto start = std::chrono::steady_clock::now();
    rtcCommitScene(e->scene_);
    e->build_ms_ =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (!e->error_.empty()) {
        error = e->error_;
        return nullptr;
    }
    return e;
}

RawEmbree::~RawEmbree() {
    if (scene_)
        rtcReleaseScene(scene_);
    if (device_)
        rtcReleaseDevice(device_);
}

void RawEmbree::intersect1(const std::vector<RayRecord>& rays, RawHits& out) const {
    const bool spheres = spheres_;
    RTCScene scene = scene_;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), kRayGrain),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                          RTCIntersectContext context;
                          rtcInitIntersectContext(&context);
                          for (std::size_t i = range.begin(); i != range.end(); ++i) {
                              RTCRayHit rh;
                              set_ray(rh.ray, rays[i]);
                              rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                              rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                              rtcIntersect1(scene, &context, &rh);
                              const bool hit = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
                              out.t[i] = hit ? rh.ray.tfar : INFINITY;
                              out.object[i] = !hit ? kMiss : spheres ? rh.hit.primID : 0u;
                              out.primitive[i] = !hit ? kMiss : spheres ? 0u : rh.hit.primID;
                          }
                      });
}

void RawEmbree::intersect16(const std::vector<RayRecord>& rays, bool coherent, RawHits& out) const {
    const bool spheres = spheres_;
    RTCScene scene = scene_;
    const std::size_t packets = (rays.size() + 15) / 16;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, packets, kPacketGrain),
        [&](const tbb::blocked_range<std::size_t>& range) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            if (coherent)
                context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
            for (std::size_t p = range.begin(); p != range.end(); ++p) {
                const std::size_t first = 16 * p;
                const int lanes = static_cast<int>(std::min<std::size_t>(16, rays.size() - first));
                alignas(64) int valid[16];
                RTCRayHit16 rh;
                for (int k = 0; k < 16; ++k) {
                    valid[k] = k < lanes ? -1 : 0;
                    set_lane(rh.ray, k,
                             rays[first + static_cast<std::size_t>(std::min(k, lanes - 1))]);
                    rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
                    rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
                }
                rtcIntersect16(valid, scene, &context, &rh);
                for (int k = 0; k < lanes; ++k) {
                    const std::size_t i = first + static_cast<std::size_t>(k);
                    const bool hit = rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;
                    out.t[i] = hit ? rh.ray.tfar[k] : INFINITY;
                    out.object[i] = !hit ? kMiss : spheres ? rh.hit.primID[k] : 0u;
                    out.primitive[i] = !hit ? kMiss : spheres ? 0u : rh.hit.primID[k];
                }
            }
        });
}

void RawEmbree::occluded1(const std::vector<RayRecord>& rays,
                          std::vector<std::uint8_t>& hit) const {
    RTCScene scene = scene_;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rays.size(), kRayGrain),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                          RTCIntersectContext context;
                          rtcInitIntersectContext(&context);
                          for (std::size_t i = range.begin(); i != range.end(); ++i) {
                              RTCRay ray;
                              set_ray(ray, rays[i]);
                              rtcOccluded1(scene, &context, &ray);
                              // Embree marks a blocked ray by setting tfar to −inf.
                              hit[i] = ray.tfar < 0.0f ? 1 : 0;
                          }
                      });
}

void RawEmbree::occluded16(const std::vector<RayRecord>& rays, bool coherent,
                           std::vector<std::uint8_t>& hit) const {
    RTCScene scene = scene_;
    const std::size_t packets = (rays.size() + 15) / 16;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, packets, kPacketGrain),
        [&](const tbb::blocked_range<std::size_t>& range) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            if (coherent)
                context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
            for (std::size_t p = range.begin(); p != range.end(); ++p) {
                const std::size_t first = 16 * p;
                const int lanes = static_cast<int>(std::min<std::size_t>(16, rays.size() - first));
                alignas(64) int valid[16];
                RTCRay16 ray;
                for (int k = 0; k < 16; ++k) {
                    valid[k] = k < lanes ? -1 : 0;
                    set_lane(ray, k,
                             rays[first + static_cast<std::size_t>(std::min(k, lanes - 1))]);
                }
                rtcOccluded16(valid, scene, &context, &ray);
                for (int k = 0; k < lanes; ++k) {
                    hit[first + static_cast<std::size_t>(k)] = ray.tfar[k] < 0.0f ? 1 : 0;
                }
            }
        });
}

}  // namespace raycastd::bench
