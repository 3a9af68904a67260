#pragma once
// EmbreeAccel: Embree 3 BVHs over a scene, answering single rays at the three precisions of
// the API. No Embree type appears here (Mitsuba's pattern: the backend stays in the .cpp).
//
//   fast     Embree's float traversal and intersection in its default (non-robust) mode, on a
//            BVH of its own built by the first fast query (the geometries are shared); spheres
//            are user geometry running the engine's double sphere test; t and the normal from
//            Embree's float hit. Batches of 16 go through Embree's packets. Not watertight.
//   refined  one float traversal of the ROBUST (watertight) BVH built with the accelerator,
//            whose triangles are widened in their planes by more than the float rounding can
//            move a ray (embree/fat_triangles.h); a hit filter decides every float candidate
//            by the double watertight test, so a float miss is a miss. The exact path decides
//            where that argument does not hold (the filter rejected a candidate before the
//            answer, a far origin, a scene with slivers); all/count run on the exact BVH.
//   exact    a second BVH, our own (embree/exact_bvh.h), over every primitive's float box
//            (padded to cover the float rounding of the ray and of the boxes), which only culls;
//            every candidate is decided by the double watertight test and the closest is chosen
//            by the API's tie rules. Built on the first exact query ("skip what nobody asked
//            for"). Until 2026-12-06 it was an Embree scene of user geometry (docs/numerics.md).
//
// Embree sees coordinates relative to the scene's centre, and the float ray starts where the
// double ray enters the (padded) scene bounds, with a unit direction: a scene far from the
// origin, a far ray origin or an extreme direction length do not cost float precision.
//
// The parts, one concept a file, in engine/accel/embree/: device (the shared RTCDevice, errors
// → Status, RAII handles), impl.h (the BVHs, RayContext, NativeHit), float_ray (clipping, the
// float ray set-ups, the one lane fill), user_geometry (the double-precision callbacks),
// exact_bvh (exact's tree and its walk), fat_triangles (refined's widened triangles and their
// hit filter), build_buffer (the triangles' float buffers, given back once Embree has built from
// them), packets
// (16-wide traversal, the one coherence test), point_query (closest points through
// rtcPointQuery). embree_accel.cpp holds the builds and, for each query, one function per
// precision.

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "engine/geometry/closest_point.h"
#include "engine/math/float_frame.h"
#include "engine/query_types.h"
#include "engine/scene/scene.h"
#include "engine/status.h"

namespace raycastd::engine {

namespace embree {
struct Impl;  // engine/accel/embree/impl.h
}

class EmbreeAccel {
  public:
    /// Builds the fast/refined BVH over `scene`, which must outlive the accelerator.
    /// Embree errors (out of memory → too_large) come back as a Status. `cancel` is asked from
    /// Embree's build progress callback, which stops the build (Code::cancelled) once it fires.
    static Result<std::unique_ptr<EmbreeAccel>> build(const Scene& scene,
                                                      const CancelToken& cancel = {});
    ~EmbreeAccel();
    EmbreeAccel(const EmbreeAccel&) = delete;
    EmbreeAccel& operator=(const EmbreeAccel&) = delete;

    /// Closest hit in [tmin, tmax] at `precision`, or nullopt.
    std::optional<Hit> closest(const Ray& ray, Precision precision, bool want_normal) const;
    /// Closest hits of rays[0..n) into out[0..n) (a miss leaves an invalid Hit). Coherent groups
    /// of 16 (camera-like rays) go through Embree's packet traversal, where it is faster; the
    /// answers are the same as closest() ray by ray.
    void closest_range(const Ray* rays, std::size_t n, Precision precision, bool want_normal,
                       Hit* out) const;
    /// Whether anything is hit in [tmin, tmax].
    bool any(const Ray& ray, Precision precision) const;
    /// any() for rays[0..n): out[i] is 1 where ray i hits anything, else 0. Groups of 16 go
    /// through Embree's occlusion packets where they can. A byte a ray rather than a Hit: a
    /// render asks this of every shadow ray, and a 72-byte Hit each, value-initialised and then
    /// written, only to be asked valid(), had cost the Duck's spp 4 render 5% of its time
    /// (bench_render, four alternating pairs, 2026-12-07: 265-269 → 252-260 ms).
    void any_range(const Ray* rays, std::size_t n, Precision precision, std::uint8_t* out) const;
    /// Every hit, sorted, shared edges merged (see linear_accel.h). fast: the candidates of
    /// refined's widened float triangles, each decided in double (spheres by fast's kernel);
    /// refined and exact: every candidate of the exact BVH decided in double.
    void all(const Ray& ray, Precision precision, bool want_normal, std::vector<Hit>& out) const;

    /// The closest surface point to p within max_distance, decided in double by the kernels of
    /// engine/geometry/closest_point.h, ties by the API's rule; Embree's point query only culls
    /// (embree/point_query.cpp). nullopt when nothing is that close.
    std::optional<PointHit> closest_point(const Vec3d& p, double max_distance) const;

    /// The frame Embree computes in (coordinates relative to the centre of the scene's bounds,
    /// of magnitude twice its diagonal): what a fast or refined answer's float rounding is
    /// measured against (math/float_frame.h).
    FloatFrame float_frame() const;

    /// Estimated bytes of the BVHs built so far.
    std::size_t memory_bytes() const;

  private:
    explicit EmbreeAccel(std::unique_ptr<embree::Impl> impl);
    std::unique_ptr<embree::Impl> impl_;
};

}  // namespace raycastd::engine
