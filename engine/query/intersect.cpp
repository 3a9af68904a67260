#include "engine/query/intersect.h"

#include <cassert>
#include <cmath>
#include <limits>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "engine/accel/embree_accel.h"
#include "engine/accel/linear_accel.h"
#include "engine/accel/scene_scan.h"
#include "engine/huge_pages.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine {

namespace {

/// Below this many rays a batch runs on the calling thread: spawning TBB tasks costs more
/// than tracing a few rays through a small scene.
constexpr std::size_t kSerialBatch = 64;

/// Scenes with at most this many primitives are answered by brute force in double precision
/// (the exact path) without building a BVH: for the tutorial's three spheres a BVH costs more
/// to build than it can ever save, and the exact answer is the cheapest one. Measured with
/// bench/bench_intersect (see docs/benchmarks.md).
constexpr std::size_t kBruteForceMaxPrimitives = 16;

/// Embree works in float, relative to the scene's centre and scaled to unit size
/// (embree::Impl::unit), so any scene size fits, bar the extremes: past 1e290 its padding and
/// twice its diagonal approach double's own range, and below 1e-290 its coordinates relative to
/// the centre are subnormal in double. Such scenes are answered by brute force in double
/// whatever their size. (Until 2026-12-05 Embree saw coordinates unscaled, and only scenes
/// between ~1e-12 and ~1e12 across were answered right: see Impl::unit.)
constexpr double kMaxFloatSceneDiagonal = 1e290;
constexpr double kMinFloatSceneDiagonal = 1e-290;

bool fits_float(const Scene& s) {
    const Bounds3 b = s.bounds();
    if (b.empty())
        return true;
    const double diagonal = scaled_length(b.diagonal());  // |d|² over- or underflows past 1e±154
    return diagonal <= kMaxFloatSceneDiagonal && diagonal >= kMinFloatSceneDiagonal;
}

/// f(i) for i in [0, n), over TBB's threads for more than kSerialBatch rays. `cancel` is asked
/// once per kBlockRays rays of each range (a range may be a large part of the batch), and once it
/// fires the rest of every range is skipped.
template <class F>
void for_each_ray(std::size_t n, const CancelToken& cancel, F&& f) {
    if (n <= kSerialBatch) {
        if (cancel.cancelled())
            return;
        for (std::size_t i = 0; i < n; ++i)
            f(i);
        return;
    }
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kSerialBatch),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t b = r.begin(); b < r.end();) {
                              if (cancel.cancelled())
                                  return;
                              const std::size_t e = std::min(r.end(), b + QueryEngine::kBlockRays);
                              for (std::size_t i = b; i != e; ++i)
                                  f(i);
                              b = e;
                          }
                      });
}

/// The fixed blocks of for_each_block.
constexpr std::size_t kBlock = QueryEngine::kBlockRays;
std::size_t block_count(std::size_t n) {
    return n <= kBlock ? 1 : (n + kBlock - 1) / kBlock;
}
std::size_t block_index(std::size_t begin) {
    return begin / kBlock;
}

/// Like for_each_ray, handing out fixed blocks of 1024 rays (whole packets of 16
/// where possible, and few enough tasks that scheduling costs nothing per ray). `cancel` is
/// asked before each block; once it fires, blocks not yet begun are skipped.
template <class F>
void for_each_block(std::size_t n, const CancelToken& cancel, F&& f) {
    if (n <= kBlock) {
        if (!cancel.cancelled())
            f(std::size_t(0), n);
        return;
    }
    // Always the same blocks, from run to run and whatever the scheduling: refined's
    // per-block choice of path (EmbreeAccel::closest_range), and hence its answer to a
    // near-tie, must not depend on which thread stole what.
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, block_count(n)),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t b = r.begin(); b != r.end(); ++b) {
                              if (cancel.cancelled())
                                  return;
                              f(b * kBlock, std::min(n, (b + 1) * kBlock));
                          }
                      });
}

}  // namespace

Status validate_ray(const Ray& ray, std::size_t index) {
    // The common case first, without building any message: a server validates every ray of a
    // 1M-ray batch, and two strings per ray cost more than the test (measured: 4% of a binary
    // request's time).
    if (is_valid_ray(ray))
        return {};
    const double len2 = dot(ray.direction, ray.direction);
    const std::string at = "/rays/" + std::to_string(index);
    const std::string which = "ray " + std::to_string(index) + ": ";
    if (!is_finite(ray.origin)) {
        return Status::error(Code::invalid_ray, which + "origin must be finite", at + "/origin");
    }
    if (!is_finite(ray.direction)) {
        return Status::error(Code::invalid_ray, which + "direction must be finite",
                             at + "/direction");
    }
    if (ray.direction == Vec3d{0.0, 0.0, 0.0}) {
        return Status::error(Code::invalid_ray, which + "direction must not be zero",
                             at + "/direction");
    }
    // |d|² must not overflow or underflow, or every quadratic and shear below breaks down.
    if (!std::isfinite(len2) || len2 == 0.0) {
        return Status::error(Code::invalid_ray, which + "direction length out of range",
                             at + "/direction");
    }
    if (std::isnan(ray.tmin) || std::isnan(ray.tmax)) {
        return Status::error(Code::invalid_ray, which + "tmin and tmax must be numbers", at);
    }
    if (ray.tmin > ray.tmax) {
        return Status::error(Code::invalid_ray, which + "tmin > tmax", at + "/tmin");
    }
    return {};
}

namespace {

/// A triangle's size as surface_point's far test measures it, from its edges ab and ac: their
/// largest coordinate. find_near_reach takes the scene's smallest by the same rule, which its
/// shortcut relies on.
double edge_size(const Vec3d& ab, const Vec3d& ac) {
    return std::max(max_abs(ab), max_abs(ac));
}

}  // namespace

bool surface_point(const Scene& scene, const Ray& ray, const Hit& hit, Vec3d& p, Vec3d& err) {
    // Far: from the distance at which sphere_normal takes the closest approach, in object sizes.
    constexpr double kFarSizes = kNormalFarRadii;
    if (hit.object >= scene.objects.size())
        return false;
    const Object& o = scene.objects[hit.object];
    if (o.kind == ObjectKind::sphere) {
        const Sphere& s = o.sphere;
        if (max_abs(ray.origin - s.center) / kFarSizes <= s.radius)
            return false;
        // The hit's own normal knows which root it is at; from afar both roots can round to one
        // t, and a normal recomputed from t alone then puts an exit on the entry side (a
        // helper's review: (0, 0.5, -0.866) for both hits of a unit sphere from 2^60 away).
        // Callers that want points ask for normals (server/schema/query_doc.cpp); without one,
        // the side is told by t.
        Vec3d n = hit.normal;
        if (n == Vec3d{0.0, 0.0, 0.0}) {
            Hit at;
            sphere_normal(s, ray, hit.t, at);
            n = at.normal;
        }
        // A normal that is not a unit vector (a hit `fast` reported from ~2^57 scene sizes away
        // on a line that misses, with a zero normal: a helper's review) would put the point at
        // the centre with a bound of ulps; such a hit keeps the sum.
        if (!(std::abs(dot(n, n) - 1.0) <= 16.0 * kDoubleUnitRoundoff))
            return false;
        const Vec3d q = s.center + n * s.radius;
        if (!is_finite(q))
            return false;
        p = q;
        // c + r·n rounds twice per component (γ₂ of |c| + r·|n|, Higham 2002 Lemma 3.1); |n|
        // within 8u of 1 (the test above) puts the point up to 8u·r off the sphere (its
        // direction's error only moves it along the sphere): γ₁₂·r holds that with a margin.
        const double off = gamma(12) * s.radius;
        err = (abs(s.center) + abs(n) * s.radius) * gamma(2) + Vec3d{off, off, off};
        return true;
    }
    if (!o.mesh || hit.primitive >= o.mesh->size())
        return false;
    const Triangle t = o.mesh->triangle(hit.primitive);
    const Vec3d ab = t.b - t.a, ac = t.c - t.a;
    const double size = edge_size(ab, ac);
    if (max_abs(ray.origin - t.a) / kFarSizes <= size)
        return false;
    const Vec3d q = t.a + ab * hit.u + ac * hit.v;
    if (!is_finite(q))
        return false;
    p = q;
    // a + u·ab + v·ac is a point of the triangle's plane but for its roundings: ab and ac
    // (u of each, times |u| and |v|) and the two products and two sums (γ₄ with them; Higham
    // 2002 Lemma 3.1). Across the plane of a triangle in z = 0 that is exactly 0, and an origin
    // moved by 0 stays on the plane, where a shadow ray hits its own triangle at t = 0 (a far
    // camera's render of such a triangle came out unlit). So the bound is never below u of the
    // triangle's size: spawn.h's offset then always moves the origin off, by enough that the
    // crossing's t, that distance over an unnormalised direction to a light, stays a normal
    // number (the least normal double alone would underflow it to −0 for a light 1e16 away, and
    // −0 ≥ tmin = 0: a review).
    const double hair = std::max(std::numeric_limits<double>::min(), kDoubleUnitRoundoff * size);
    err = (abs(t.a) + abs(ab) * std::abs(hit.u) + abs(ac) * std::abs(hit.v)) * gamma(4) +
          Vec3d{hair, hair, hair};
    return true;
}

Vec3d hit_point(const Scene& scene, const Ray& ray, const Hit& hit) {
    Vec3d p, err;
    return surface_point(scene, ray, hit, p, err) ? p : ray.at(hit.t);
}

std::optional<Hit> closest_by_brute_force(const Scene& scene, const Ray& ray, bool want_normal,
                                          const CancelToken& cancel) {
    // As QueryEngine answers a brute-force scene (far rays moved for its meshes), so that
    // explain's first hit is intersect's (a helper's review: 1,113 of 2,000 far rays differed).
    return linear_closest_from_afar(scene, scene_ball(scene), ray, want_normal,
                                    cancel.can_fire() ? &cancel : nullptr);
}

std::optional<Hit> closest_in_object_by_brute_force(const Scene& scene, std::uint32_t object,
                                                    const Ray& ray, bool want_normal,
                                                    const CancelToken& cancel) {
    return linear_closest_in_object(scene, object, ray, want_normal,
                                    cancel.can_fire() ? &cancel : nullptr);
}

QueryEngine::QueryEngine(std::shared_ptr<const Scene> scene) : scene_(std::move(scene)) {}
QueryEngine::~QueryEngine() = default;

Result<std::shared_ptr<const QueryEngine>> QueryEngine::build(std::shared_ptr<const Scene> scene,
                                                              const CancelToken& cancel) {
    if (!scene)
        return Status::error(Code::internal, "no scene");
    Status st = validate(*scene);
    if (!st.ok())
        return st;
    if (cancel.cancelled())
        return cancel.status();
    std::shared_ptr<QueryEngine> engine(new QueryEngine(std::move(scene)));
    engine->scene_bytes_ = engine->scene_memory_bytes();
    // The meshes' topology (engine/mesh: for the point queries and the scene's `topology`),
    // before the BVH rather than beside it: on a thread of its own it raced Embree's build for
    // the cores and cost ~300 ms more CPU on 1M triangles than the two one after the other
    // (TBB's workers spin while they wait; bench_points --registration-only, docs/loading.md).
    engine->prepare_points();
    engine->prepare_normals();
    if (cancel.cancelled())
        return cancel.status();
    const std::size_t prims = engine->scene_->triangle_count() + engine->scene_->sphere_count();
    if (prims > kBruteForceMaxPrimitives && fits_float(*engine->scene_)) {
        auto accel = EmbreeAccel::build(*engine->scene_, cancel);
        if (!accel.ok())
            return accel.status();
        engine->accel_ = std::move(*accel);
    } else {
        engine->ball_ = std::make_unique<const SceneBall>(scene_ball(*engine->scene_));
    }
    engine->find_near_reach();
    return std::shared_ptr<const QueryEngine>(std::move(engine));
}

bool QueryEngine::surface_point(const Ray& ray, const Hit& hit, Vec3d& p, Vec3d& err) const {
    return !near_every_object(ray) && engine::surface_point(*scene_, ray, hit, p, err);
}

Vec3d QueryEngine::point_of(const Ray& ray, const Hit& hit) const {
    Vec3d p, err;
    return surface_point(ray, hit, p, err) ? p : ray.at(hit.t);
}

void QueryEngine::find_near_reach() {
    // The sizes surface_point() compares with: a sphere's radius, a triangle's largest edge
    // coordinate from its first corner.
    const Scene& s = *scene_;
    double smallest = kInfinity;
    for (const Object& o : s.objects) {
        if (o.kind == ObjectKind::sphere) {
            smallest = std::min(smallest, o.sphere.radius);
            continue;
        }
        for (std::size_t p = 0; p < o.mesh->size(); ++p) {
            const Triangle t = o.mesh->triangle(p);
            const double size = edge_size(t.b - t.a, t.c - t.a);
            // A triangle whose corners coincide is never hit, in double or in float (a
            // review: one such triangle, common in real meshes, had turned the shortcut off
            // for the whole scene).
            if (size > 0.0)
                smallest = std::min(smallest, size);
        }
    }
    const Bounds3 b = s.bounds();
    if (b.empty() || !std::isfinite(smallest))
        return;
    // Every object point a lies within `half` of the centre on each axis, so an origin within
    // 2²⁰·smallest − half of it lies within 2²⁰·smallest of a. Both sides are rounded towards
    // that: 2⁻²⁰ of each is more than the roundings of the extent, of o − centre and of the
    // per-object tests, but not the centre's own rounding, u·|centre|, which for a scene far
    // from the world origin can exceed its objects (two spheres of radius 1.01 at 2⁶⁶ and
    // 2⁶⁶ + 2¹⁴, whose centre rounded onto the first: a helper's review), so that is taken off
    // too.
    near_centre_ = 0.5 * (b.lo + b.hi);
    const double half = max_abs(b.hi - b.lo) * 0.5;
    near_reach_ = kNormalFarRadii * smallest * (1.0 - 0x1p-20) - half * (1.0 + 0x1p-20) -
                  2.0 * kDoubleUnitRoundoff * max_abs(near_centre_);
    if (!std::isfinite(near_reach_))
        near_reach_ = -1.0;
}

Precision QueryEngine::effective_precision(Precision asked) const {
    return accel_ ? asked : Precision::exact;
}

std::optional<Hit> QueryEngine::closest(const Ray& ray, Precision precision,
                                        bool want_normal) const {
    if (!accel_)
        return linear_closest_from_afar(*scene_, *ball_, ray, want_normal);
    return accel_->closest(ray, precision, want_normal);
}

bool QueryEngine::occluded(const Ray& ray, Precision precision) const {
    if (!accel_)
        return linear_any_from_afar(*scene_, *ball_, ray);
    return accel_->any(ray, precision);
}

FloatFrame QueryEngine::float_frame(Precision precision) const {
    if (effective_precision(precision) == Precision::exact)
        return FloatFrame{};
    return accel_->float_frame();
}

std::unique_ptr<SceneScan> QueryEngine::scan_for_many_rays(Precision precision) const {
    const std::size_t prims = scene_->triangle_count() + scene_->sphere_count();
    if (accel_ || prims == 0 || prims > kBruteForceMaxPrimitives)
        return nullptr;
    return std::make_unique<SceneScan>(*scene_, precision == Precision::fast);
}

std::size_t QueryEngine::memory_bytes() const {
    // The scene's part is fixed once built; the accelerator's grows when a query builds the
    // exact or the fast BVH.
    return scene_bytes_ + (accel_ ? accel_->memory_bytes() : 0) + point_memory_bytes() +
           normals_memory_bytes();
}

std::size_t QueryEngine::scene_memory_bytes() const {
    std::size_t bytes = sizeof(Scene);
    for (const Object& o : scene_->objects) {
        bytes += sizeof(Object) + o.name.size();
        if (o.mesh) {
            bytes += o.mesh->positions.capacity() * sizeof(Vec3d) +
                     o.mesh->triangles.capacity() * sizeof(o.mesh->triangles[0]) +
                     o.mesh->normals.capacity() * sizeof(Vec3f) +
                     o.mesh->triangle_material.capacity() * sizeof(std::uint32_t) +
                     o.mesh->corner_uvs.capacity() * sizeof(o.mesh->corner_uvs[0]);
        }
    }
    return bytes + scene_->texture_bytes();
}

QueryResult QueryEngine::intersect(const std::vector<Ray>& rays, const QueryOptions& opt) const {
    assert(!opt.cancel.can_fire() && "a batch that may be cancelled needs the Status overload");
    QueryResult out;
    intersect(rays, opt, out);
    return out;
}

void QueryEngine::intersect_span(const Ray* rays, std::size_t n, const QueryOptions& opt,
                                 Hit* hits) const {
    assert(opt.mode == Mode::closest || opt.mode == Mode::any);
    const Precision p = effective_precision(opt.precision);
    const EmbreeAccel* accel = accel_.get();
    if (opt.mode == Mode::closest) {
        if (accel) {
            for_each_block(n, opt.cancel, [&](std::size_t b, std::size_t e) {
                accel->closest_range(rays + b, e - b, p, opt.want_normal, hits + b);
            });
            return;
        }
        for_each_ray(n, opt.cancel, [&](std::size_t i) {
            auto h = linear_closest_from_afar(*scene_, *ball_, rays[i], opt.want_normal);
            hits[i] = h ? *h : Hit{};
        });
        return;
    }
    // An `any` answer as a Hit: valid() says whether the ray hits anything; nothing else is
    // filled in (query_result.h).
    const auto answer = [](bool blocked) {
        Hit h;
        if (blocked)
            h.object = 0;
        return h;
    };
    if (accel) {
        for_each_block(n, opt.cancel, [&](std::size_t b, std::size_t e) {
            std::uint8_t blocked[kBlockRays];
            accel->any_range(rays + b, e - b, p, blocked);
            for (std::size_t i = b; i < e; ++i)
                hits[i] = answer(blocked[i - b] != 0);
        });
        return;
    }
    for_each_ray(n, opt.cancel, [&](std::size_t i) {
        // `any` never looks for the closest: it stops at the first hit found.
        hits[i] = answer(linear_any_from_afar(*scene_, *ball_, rays[i]));
    });
}

void QueryEngine::occluded_batch(const Ray* rays, std::size_t n, Precision precision,
                                 std::uint8_t* blocked) const {
    const Precision p = effective_precision(precision);
    const CancelToken never;
    if (const EmbreeAccel* accel = accel_.get()) {
        // The blocks of intersect_span, so the same answers as a batch in mode `any`.
        for_each_block(n, never, [&](std::size_t b, std::size_t e) {
            accel->any_range(rays + b, e - b, p, blocked + b);
        });
        return;
    }
    for_each_ray(n, never, [&](std::size_t i) {
        blocked[i] = linear_any_from_afar(*scene_, *ball_, rays[i]) ? 1 : 0;
    });
}

Status QueryEngine::intersect_blocks(std::size_t n, const QueryOptions& opt,
                                     const BlockSource& source, const BlockSink& sink) const {
    for_each_block(n, opt.cancel, [&](std::size_t b, std::size_t e) {
        // Isolated: a brute-force scene traces a block with a parallel loop of its own, and a
        // thread waiting in it must not take up another block of this or any other batch, which
        // would reuse the thread's buffers under the first block's feet (found in review: wrong
        // answers with 8 or more threads; BatchesOnManyThreadsKeepTheirBlocksApart).
        tbb::this_task_arena::isolate([&] {
            // One block of each per thread, reused: 64 + 72 KB, which stay in L2.
            thread_local std::vector<Ray> rays;
            thread_local std::vector<Hit> hits;
            rays.resize(e - b);
            hits.resize(e - b);
            if (!source(b, e, rays.data()))
                return;
            // A block that starts on a multiple of kBlockRays: intersect_span answers it as
            // part of the whole batch.
            intersect_span(rays.data(), e - b, opt, hits.data());
            sink(b, e, hits.data());
        });
    });
    return opt.cancel.status();
}

Status QueryEngine::intersect(const std::vector<Ray>& rays, const QueryOptions& opt,
                              QueryResult& out) const {
    // hits is not cleared here: closest and any overwrite every answer of a reused buffer
    // (clearing first would make resize fill it all again); all and count clear it.
    out.offsets.clear();
    out.counts.clear();
    out.precision = effective_precision(opt.precision);
    const Precision p = out.precision;
    const std::size_t n = rays.size();
    const Scene& s = *scene_;
    const EmbreeAccel* accel = accel_.get();
    switch (opt.mode) {
        case Mode::closest:
        case Mode::any:
            reserve_fresh(out.hits, n);  // engine/huge_pages.h: first touch of 72 B a ray
            out.hits.resize(n);          // intersect_span writes every answer
            intersect_span(rays.data(), n, opt, out.hits.data());
            break;
        case Mode::all:
        case Mode::count: {
            // One scratch vector per block instead of one vector per ray (a million small
            // allocations for a 1M-ray batch): each block's hits are appended to its own list,
            // and `all` concatenates the lists in block order.
            const bool normals = opt.want_normal && opt.mode == Mode::all;
            const bool keep = opt.mode == Mode::all;
            out.hits.clear();
            out.counts.resize(n);
            std::vector<std::vector<Hit>> block_hits(keep ? block_count(n) : 0);
            for_each_block(n, opt.cancel, [&](std::size_t b, std::size_t e) {
                std::vector<Hit> one;
                std::vector<Hit>* mine = keep ? &block_hits[block_index(b)] : nullptr;
                for (std::size_t i = b; i < e; ++i) {
                    if (accel) {
                        accel->all(rays[i], p, normals, one);
                    } else {
                        linear_all_from_afar(s, *ball_, rays[i], normals, one);
                    }
                    out.counts[i] = static_cast<std::uint32_t>(one.size());
                    if (mine)
                        mine->insert(mine->end(), one.begin(), one.end());
                }
            });
            if (!keep || opt.cancel.fired())
                break;
            out.offsets.resize(n + 1);
            out.offsets[0] = 0;
            for (std::size_t i = 0; i < n; ++i)
                out.offsets[i + 1] = out.offsets[i] + out.counts[i];
            out.counts.clear();  // all answers with offsets (query_result.h)
            out.hits.reserve(out.offsets[n]);
            for (auto& v : block_hits)
                out.hits.insert(out.hits.end(), v.begin(), v.end());
            break;
        }
    }
    return opt.cancel.status();
}

}  // namespace raycastd::engine
