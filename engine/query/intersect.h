#pragma once
// The query modes of the API over one prepared scene: closest, any, all and count, at the
// precision asked for. The scene and its acceleration structure are immutable once built and
// shared by every request thread.

#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "engine/geometry/closest_point.h"
#include "engine/math/float_frame.h"
#include "engine/mesh/topology.h"
#include "engine/mesh/vertex_normals.h"
#include "engine/query/query_result.h"
#include "engine/scene/scene.h"
#include "engine/status.h"

namespace raycastd::engine {

class EmbreeAccel;
class SceneScan;
struct SceneBall;
struct WindingTrees;     // query/point_entry.cpp
struct PointTree;        // query/point_entry.cpp
struct ParityPieces;     // query/parity_pieces.h
struct ParitySlot;       // query/point_entry.cpp
struct ComputedNormals;  // query/shading_normals.cpp

/// A scene made ready for queries.
class QueryEngine {
  public:
    /// Validates the scene and builds what its size calls for. Never throws. Code::cancelled
    /// once `cancel` has fired (asked before the BVH build and during it).
    static Result<std::shared_ptr<const QueryEngine>> build(std::shared_ptr<const Scene> scene,
                                                            const CancelToken& cancel = {});

    const Scene& scene() const { return *scene_; }
    const std::shared_ptr<const Scene>& scene_ptr() const { return scene_; }

    /// Answers every ray; rays must already be valid (finite, non-zero direction, tmin ≤ tmax).
    /// For callers that never cancel: options.cancel must be a default token (asserted).
    QueryResult intersect(const std::vector<Ray>& rays, const QueryOptions& options) const;
    /// The same, into `out`, whose buffers keep their capacity: a server thread that reuses one
    /// QueryResult does not page-fault fresh megabytes on every large batch. Code::cancelled
    /// (out then incomplete) once options.cancel has fired; it is asked once per block.
    Status intersect(const std::vector<Ray>& rays, const QueryOptions& options,
                     QueryResult& out) const;

    /// Rays are traced in fixed blocks of this many, whatever the threads do (see intersect.cpp).
    static constexpr std::size_t kBlockRays = 1024;
    /// closest or any (options.mode must be one of them) for rays[0..n) into hits[0..n); every
    /// element is written. A span that starts at a multiple of kBlockRays of a batch gets the
    /// answers intersect() gives those rays of the whole batch, so a server may trace a batch in
    /// pieces while the rest of it is still arriving. Once options.cancel fires, blocks not yet
    /// begun are left unwritten (the caller asks options.cancel.fired()).
    void intersect_span(const Ray* rays, std::size_t n, const QueryOptions& options,
                        Hit* hits) const;

    /// Fills rays[0 .. end-begin) with rays [begin, end) of the caller's batch; false when one
    /// of them is invalid (that block is then neither traced nor stored).
    using BlockSource = std::function<bool(std::size_t begin, std::size_t end, Ray* rays)>;
    /// Takes the answers hits[0 .. end-begin) of rays [begin, end).
    using BlockSink = std::function<void(std::size_t begin, std::size_t end, const Hit* hits)>;
    /// closest or any over a batch of n rays the caller keeps in its own format (e.g. float
    /// records): each block of kBlockRays is fetched by `source` into a per-thread buffer,
    /// traced as intersect_span traces it, and handed to `sink`. Answers equal intersect()'s,
    /// but the batch never exists as 64-byte rays and 72-byte hits: the block buffers stay in
    /// cache, and memory traffic is the caller's records alone (bench_intersect's
    /// QueryEngine::intersect_blocks rows against its QueryEngine::intersect rows: 5-15% faster
    /// on 1M rays). Blocks run isolated (tbb::this_task_arena::isolate). options.cancel is asked
    /// before each block; once it fires, blocks not yet begun are neither fetched nor handed to
    /// `sink`, and the call returns Code::cancelled.
    Status intersect_blocks(std::size_t n, const QueryOptions& options, const BlockSource& source,
                            const BlockSink& sink) const;

    /// The path a request asking for `asked` is answered by (tiny scenes always take exact).
    Precision effective_precision(Precision asked) const;

    /// The closest hit of one ray in [tmin, tmax] at `precision`, or nullopt: the answer
    /// intersect() gives a batch of this one ray (mode closest), without a batch around it. The
    /// ray must be valid.
    std::optional<Hit> closest(const Ray& ray, Precision precision, bool want_normal) const;
    /// Whether anything lies along `ray` in [tmin, tmax] (a shadow ray's question) at
    /// `precision` (EmbreeAccel::any: refined is one traversal whose misses need no
    /// confirmation, except in a scene with slivers, where it takes the exact path).
    bool occluded(const Ray& ray, Precision precision) const;
    /// occluded() of rays[0..n) into blocked[0..n) (1 blocked, 0 free): the answers of
    /// intersect() in mode `any`, a byte a ray instead of a 72-byte Hit (a render's shadow
    /// rays, which ask nothing else). Never cancelled; the rays must be valid.
    void occluded_batch(const Ray* rays, std::size_t n, Precision precision,
                        std::uint8_t* blocked) const;
    /// The float frame of the path that answers `precision` (math/float_frame.h): Embree's for
    /// fast and refined on a BVH, none (scale 0) where the answer is decided in double.
    FloatFrame float_frame(Precision precision) const;

    /// Estimated bytes held by the scene and its acceleration structures, including the BVHs
    /// built since by the first exact or fast query (cheap: no walk over the scene).
    std::size_t memory_bytes() const;

    /// True when no BVH is built: the scene is small enough that brute force beats one, or wider
    /// than float can hold (answered in double at every precision).
    bool brute_force() const { return accel_ == nullptr; }

    /// True only if `ray`'s origin lies within 2²⁰ object sizes of every object of the scene, so
    /// that hit_point is origin + t·direction for any of its hits and surface_point() false: a
    /// sufficient test against the scene's bounds and its smallest object (made once by
    /// build(); triangles whose corners coincide, never hit, do not count), which lets a
    /// renderer or a JSON answer skip reading each hit's primitive. False for every ray where
    /// 2²⁰ times the smallest object does not exceed the scene's half-extent.
    bool near_every_object(const Ray& ray) const {
        const Vec3d q = ray.origin - near_centre_;
        return std::abs(q.x) <= near_reach_ && std::abs(q.y) <= near_reach_ &&
               std::abs(q.z) <= near_reach_;
    }
    /// surface_point over this engine's scene (below), without reading the hit's primitive where
    /// near_every_object(ray) says the point is the sum (false then).
    bool surface_point(const Ray& ray, const Hit& hit, Vec3d& p, Vec3d& err) const;
    /// hit_point the same way: the surface point where there is one, else the sum.
    Vec3d point_of(const Ray& ray, const Hit& hit) const;

    // ---- Point queries: what engine/points builds closest points, distances and inside/outside
    // on (query/point_entry.cpp). ----

    /// The closest surface point to p within max_distance (inclusive), in double (kernels of
    /// geometry/closest_point.h), ties by the API's rule; nullopt when nothing is that close. p
    /// must be finite. Above 16 primitives a tree culls: the point BVH of accel/point_bvh.h,
    /// built on the first call (where it suits the scene), else Embree's point query.
    std::optional<PointHit> closest_point(const Vec3d& p, double max_distance) const;
    /// Builds the point BVH now, if the scene uses one and it is not built yet (as the first
    /// closest_point would). A large batch calls it before its parallel loop: built inside the
    /// loop's first task, the other workers waited on it rather than helping with its parallel
    /// subtrees (bench_points: the first batch on A 2.9 s against 2.4 s for the next).
    void build_point_tree() const;
    /// Each object's topology (engine/mesh/topology.h), computed at build (objects in parallel,
    /// before the BVH); the entry of a sphere is all zeros.
    const std::vector<MeshTopology>& topology() const { return topology_; }
    /// The generalized winding number of triangle object `object` at p, by fast winding numbers
    /// (accel/winding_bvh.h); the object's tree is built on its first such query.
    double winding_number(std::uint32_t object, const Vec3d& p) const;
    /// The components of the parity meshes and the grid of their boxes (query/parity_pieces.h),
    /// built on the first call (thread-safe) and kept with the engine (counted in memory_bytes).
    const ParityPieces& parity_pieces() const;

    // ---- Shading (query/shading_normals.cpp). ----

    /// The shading normals of mesh object `object` when its file gives none: area-weighted
    /// vertex normals split at creases (mesh/vertex_normals.h), computed on the first call for
    /// that object (thread-safe; registration does not pay for scenes never rendered) and kept
    /// with the engine (counted in memory_bytes). nullptr for spheres, lone triangles (their
    /// normal is the geometric one) and meshes with their own vertex normals.
    const CornerNormals* computed_normals(std::uint32_t object) const;

    ~QueryEngine();

  private:
    friend class Tracer;  // query/tracer.h: BuildHint::many_rays asks for scan_for_many_rays()
    explicit QueryEngine(std::shared_ptr<const Scene> scene);
    /// A scan of its own (accel/scene_scan.h) for a caller about to trace many rays at
    /// `precision` through a scene this engine answers by brute force because it is small (at
    /// most 16 primitives; a render): the same exact answers without linear_closest's overheads,
    /// or fast's kernels at `fast`. nullptr where the engine's own path stays: it has a BVH, the
    /// scene is empty, or it has more than 16 primitives (brute force only for being wider than
    /// float; a small scene that wide is scanned, in double).
    std::unique_ptr<SceneScan> scan_for_many_rays(Precision precision) const;
    /// near_centre_ and near_reach_, by build().
    void find_near_reach();
    std::size_t scene_memory_bytes() const;
    /// point_entry.cpp: each object's topology (objects in parallel) and the empty winding-tree
    /// slots; run by build() before the BVH.
    void prepare_points();
    /// Bytes of the winding-number trees and of the point BVH built so far.
    std::size_t point_memory_bytes() const;
    std::shared_ptr<const Scene> scene_;
    std::size_t scene_bytes_ = 0;  ///< scene_memory_bytes(), once
    std::unique_ptr<EmbreeAccel> accel_;
    /// Around a brute-force scene (no accel_): its far rays are moved to it (accel/far_ray.h).
    std::unique_ptr<const SceneBall> ball_;
    /// near_every_object(): the centre of the scene's bounds, and how far from it (on every
    /// axis) an origin is still within 2²⁰ sizes of the smallest object from every object;
    /// negative where no origin is.
    Vec3d near_centre_;
    double near_reach_ = -1.0;
    std::vector<MeshTopology> topology_;  ///< per object (point_entry.cpp)
    /// Built per object on first use; shared_ptr, whose deleter is made where the type is complete.
    std::shared_ptr<WindingTrees> winding_;
    std::shared_ptr<PointTree> point_tree_;     ///< the same, one slot; null where it does not suit
    std::shared_ptr<ParitySlot> parity_;        ///< the same, one slot
    std::shared_ptr<ComputedNormals> normals_;  ///< the same, for computed_normals()
    /// shading_normals.cpp: the empty slots, made by build().
    void prepare_normals();
    /// Bytes of the computed normals built so far.
    std::size_t normals_memory_bytes() const;
};

/// Whether a ray meets the API's rules: finite origin and direction, |d|² neither zero nor
/// overflowing, tmin and tmax numbers with tmin ≤ tmax. Inline and message-free, for checking
/// millions of rays; validate_ray says what is wrong.
inline bool is_valid_ray(const Ray& ray) {
    const Vec3d& o = ray.origin;
    const Vec3d& d = ray.direction;
    const double len2 = dot(d, d);  // as validate_ray computes it
    // tmin <= tmax is false when either is NaN.
    return std::isfinite(o.x) && std::isfinite(o.y) && std::isfinite(o.z) && std::isfinite(d.x) &&
           std::isfinite(d.y) && std::isfinite(d.z) && std::isfinite(len2) && len2 > 0.0 &&
           ray.tmin <= ray.tmax;
}

/// Checks one ray against the API's rules; the message names the ray index.
Status validate_ray(const Ray& ray, std::size_t index);

/// The point of a hit, for answers: origin + t·direction, as API.md defines it, unless the ray
/// comes from more than 2²⁰ of the object's sizes away (from its sphere's centre, or its
/// triangle's first corner). That sum rounds by u·|origin|: from -2⁶⁶·(1, 1, 1) a triangle's hit
/// at (0.1, 0.1, 0.1) came out as (0, 0, 0) (a helper's review). There the point is taken on the
/// surface instead, to the object's own precision: (1−u−v)·a + u·b + v·c with the hit's
/// barycentrics (a far ray's come from the ray moved to the scene, docs/numerics.md), or c + r·n
/// with the hit's normal (from the closest approach, geometry/sphere.h; a hit without one gets
/// the normal at t, whose side is ambiguous where both roots round to one t: ask for normals).
/// Both agree with origin + t·direction within t's own error; nearer rays keep that sum, bit for
/// bit.
Vec3d hit_point(const Scene& scene, const Ray& ray, const Hit& hit);

/// hit_point's point where it is taken on the surface (a ray from more than 2²⁰ object sizes
/// away), with a per-component bound `err` on its distance from the surface: what an origin
/// spawned there must clear (shade/spawn.h). Its place along the surface is only as good as
/// the hit's barycentrics or normal, which is not counted: a spawned origin moves along the
/// normal. false, and `p` and `err` untouched, where the point is origin + t·direction (then
/// shade/spawn.h's hit_point_error bounds it).
bool surface_point(const Scene& scene, const Ray& ray, const Hit& hit, Vec3d& p, Vec3d& err);

/// The closest hit over `scene` as it is, without a QueryEngine: every primitive tested in
/// double (the exact path, by brute force), or nullopt; a far ray's meshes answered on the ray
/// moved to the scene, as QueryEngine's brute-force path does (linear_closest_from_afar). For
/// work on a scene that is not prepared for queries (the tutorial's worked solution,
/// engine/explain). `cancel` is asked once
/// per 65,536 triangles; once it has fired the answer is nullopt (the caller asks fired()).
std::optional<Hit> closest_by_brute_force(const Scene& scene, const Ray& ray, bool want_normal,
                                          const CancelToken& cancel = {});
/// The same over the primitives of one object (`object` and `primitive` filled in).
std::optional<Hit> closest_in_object_by_brute_force(const Scene& scene, std::uint32_t object,
                                                    const Ray& ray, bool want_normal,
                                                    const CancelToken& cancel = {});

}  // namespace raycastd::engine
