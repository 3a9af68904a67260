#pragma once
// The ceiling: a minimal program of ours calling Embree 3 directly, the way the Embree
// `minimal` tutorial does (rtcNewDevice → triangle or point-sphere geometry → rtcCommitScene →
// rtcIntersect1 / rtcIntersect16), parallelised over rays with TBB. Nothing clever: this is what
// a user would write instead of sending rays to raycastd, so raycastd is measured against it.
//
// Debian's Embree is built with ray masks enabled: every ray sets mask = 0xFFFFFFFF, or it
// would miss everything (the geometry mask defaults to all ones).

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "bench/workloads.h"

struct RTCDeviceTy;
struct RTCSceneTy;

namespace raycastd::bench {

/// Closest hits in the API's numbering: for the triangle workloads object 0 and the triangle
/// index; for the sphere workload the sphere index as object and primitive 0. A miss has
/// t = +inf and object = primitive = 0xFFFFFFFF.
struct RawHits {
    std::vector<float> t;
    std::vector<std::uint32_t> object;
    std::vector<std::uint32_t> primitive;

    /// Sizes the buffers and writes every element once, so that timed runs do not pay for the
    /// first touch of fresh pages (~2.5 ms per MB on this machine).
    void prepare(std::size_t n);
    std::size_t hit_count() const;
};

enum class BuildQuality { low, medium, high };
const char* to_string(BuildQuality q);

class RawEmbree {
  public:
    /// Builds the device and the scene; nullptr with `error` set if Embree reports an error.
    /// `robust` sets RTC_SCENE_FLAG_ROBUST (watertight traversal, ~10% slower).
    static std::unique_ptr<RawEmbree> build(const Workload& w, BuildQuality quality, bool robust,
                                            std::string& error);
    ~RawEmbree();
    RawEmbree(const RawEmbree&) = delete;
    RawEmbree& operator=(const RawEmbree&) = delete;

    /// Milliseconds spent in rtcCommitScene (the BVH build).
    double build_ms() const { return build_ms_; }

    /// rtcIntersect1 per ray, rays spread over the TBB threads. `out` must be prepared.
    void intersect1(const std::vector<RayRecord>& rays, RawHits& out) const;
    /// rtcIntersect16 on 16 consecutive rays at a time (the camera rays come in 4×4 tiles);
    /// `coherent` sets the context's COHERENT hint.
    void intersect16(const std::vector<RayRecord>& rays, bool coherent, RawHits& out) const;
    /// rtcOccluded1 per ray: hit[i] = 1 when ray i is blocked. `hit` must be sized.
    void occluded1(const std::vector<RayRecord>& rays, std::vector<std::uint8_t>& hit) const;
    /// rtcOccluded16 on 16 consecutive rays at a time.
    void occluded16(const std::vector<RayRecord>& rays, bool coherent,
                    std::vector<std::uint8_t>& hit) const;

    /// "3.13.5" — the Embree the program is linked against.
    static std::string version();

  private:
    RawEmbree() = default;
    RTCDeviceTy* device_ = nullptr;
    RTCSceneTy* scene_ = nullptr;
    bool spheres_ = false;
    double build_ms_ = 0.0;
    std::string error_;  ///< the first error the device reported
};

}  // namespace raycastd::bench
