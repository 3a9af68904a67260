#pragma once
// Tracer: single rays and small batches at one precision over a QueryEngine, for callers that
// trace ray by ray (the Whitted shader, renders). It answers as QueryEngine does, with one
// difference the caller asks for by BuildHint::many_rays: QueryEngine answers a scene of at
// most 16 primitives by brute force in exact precision through linear_accel.h, the cheapest
// for a few rays. A many-rays tracer scans such a scene through a flat copy of its own
// (accel/scene_scan.h): at refined and exact the same exact answers bit for bit, at fast the
// fast kernels, except for a ray from so far away (SceneBall::far) that the brute force moves
// it to the scene first, which the scan does not: such a ray gets the brute force's exact
// answer at every precision. bench_render's tutorial_like (four spheres and a floor), spp 4:
// refined through the Embree BVH this replaced 2,545-3,020 ms, scanned 1,423-1,798 ms; fast
// 1.2x faster.

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "engine/math/float_frame.h"
#include "engine/query/intersect.h"

namespace raycastd::engine {

/// How many rays a Tracer is about to trace.
enum class BuildHint {
    few_rays,   ///< a ray tree, a handful of rays: QueryEngine's own paths are the cheapest
    many_rays,  ///< a render: worth a scan of its own where QueryEngine answers by brute force
};

/// Closest hits and occlusion of single rays (and closest hits of batches) at one precision;
/// immutable once made, shared by the threads of a render. Rays must be valid.
class Tracer {
  public:
    /// A tracer over `engine` (which must outlive it) at `precision`.
    Tracer(const QueryEngine& engine, Precision precision, BuildHint hint);
    ~Tracer();
    Tracer(const Tracer&) = delete;
    Tracer& operator=(const Tracer&) = delete;

    /// The path that answers (QueryEngine::effective_precision; a scan of the tracer's own
    /// answers fast at fast, but for far rays, which are answered exactly, and exact
    /// otherwise).
    Precision precision() const;
    /// The float frame of that path: what a spawned ray's origin error must add (shade/spawn.h);
    /// scale 0 where the answer is decided in double.
    const FloatFrame& float_frame() const { return frame_; }
    /// Whether this tracer scans a scene of at most 16 primitives itself (BuildHint::many_rays
    /// over a scene QueryEngine answers by brute force).
    bool scans() const { return scan_ != nullptr; }

    /// The closest hit along `ray`, or nullopt.
    std::optional<Hit> closest(const Ray& ray, bool want_normal) const;
    /// Closest hits (normals included) of a batch into out[0..n) (resized; a miss leaves an
    /// invalid Hit). Runs of 16 coherent rays go through Embree's packets where that is faster.
    void closest_batch(const std::vector<Ray>& rays, std::vector<Hit>& out) const;
    /// The same for rays[0..n) into out[0..n), every element written (a caller's reused
    /// buffer: engine/thread_scratch.h).
    void closest_batch(const Ray* rays, std::size_t n, Hit* out) const;
    /// Whether anything lies along `ray` within [tmin, tmax]: QueryEngine::occluded, or the
    /// tracer's own scan.
    bool occluded(const Ray& ray) const;
    /// occluded() for a batch: blocked[i] is 1 where rays[i] is blocked, else 0 (blocked is
    /// resized). Runs of 16 coherent rays go through Embree's occlusion packets (rtcOccluded16)
    /// where that is faster (QueryEngine::occluded_batch).
    void occluded_batch(const std::vector<Ray>& rays, std::vector<std::uint8_t>& blocked) const;
    /// The same for rays[0..n) into blocked[0..n).
    void occluded_batch(const Ray* rays, std::size_t n, std::uint8_t* blocked) const;

  private:
    const QueryEngine& engine_;
    Precision precision_;
    std::unique_ptr<SceneScan> scan_;  ///< many_rays over a brute-force scene
    FloatFrame frame_;
};

}  // namespace raycastd::engine
