#pragma once
// Tracer: single rays and small batches at one precision over a QueryEngine, for callers that
// trace ray by ray (the Whitted shader, renders). It answers as QueryEngine does, with one
// difference the caller asks for by BuildHint::many_rays: QueryEngine answers a scene of at
// most 16 primitives by brute force in exact precision, the cheapest for a few rays but not for
// the millions of a render (every ray pays the double-double sphere test on every primitive:
// 0.6× POV-Ray's speed on the bench's six-primitive scene). A many-rays tracer then builds a
// BVH of its own over the scene (microseconds for 16 primitives) and traces at the precision
// asked; it is freed with the tracer.

#include <memory>
#include <optional>
#include <vector>

#include "engine/math/float_frame.h"
#include "engine/query/intersect.h"

namespace raycastd::engine {

/// How many rays a Tracer is about to trace.
enum class BuildHint {
    few_rays,   ///< a ray tree, a handful of rays: QueryEngine's own paths are the cheapest
    many_rays,  ///< a render: worth a BVH even where QueryEngine answers by brute force
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

    /// The path that answers (QueryEngine::effective_precision, or the precision asked on a
    /// BVH of the tracer's own).
    Precision precision() const;
    /// The float frame of that path: what a spawned ray's origin error must add (shade/spawn.h);
    /// scale 0 where the answer is decided in double.
    const FloatFrame& float_frame() const { return frame_; }
    /// Whether this tracer traces through a BVH of its own (a scene of at most 16 primitives
    /// that QueryEngine answers by brute force, BuildHint::many_rays).
    bool own_bvh() const { return own_bvh_ != nullptr; }

    /// The closest hit along `ray`, or nullopt.
    std::optional<Hit> closest(const Ray& ray, bool want_normal) const;
    /// Closest hits (normals included) of a batch into out[0..n) (resized; a miss leaves an
    /// invalid Hit). Runs of 16 coherent rays go through Embree's packets where that is faster.
    void closest_batch(const std::vector<Ray>& rays, std::vector<Hit>& out) const;
    /// Whether anything lies along `ray` within [tmin, tmax]: QueryEngine::occluded, or the
    /// tracer's own BVH at the precision asked (EmbreeAccel::any either way).
    bool occluded(const Ray& ray) const;
    /// occluded() for a batch: out[i].valid() says whether rays[i] is blocked (out is resized).
    /// Runs of 16 coherent rays go through Embree's occlusion packets (rtcOccluded16) where
    /// that is faster; at `refined` a float miss is confirmed as for single rays.
    void occluded_batch(const std::vector<Ray>& rays, std::vector<Hit>& out) const;

  private:
    const QueryEngine& engine_;
    Precision precision_;
    std::unique_ptr<EmbreeAccel> own_bvh_;  ///< many_rays over a brute-force scene
    FloatFrame frame_;
};

}  // namespace raycastd::engine
