#include "engine/accel/embree_accel.h"

#include <algorithm>
#include <cmath>

#include <embree3/rtcore.h>

#include "engine/accel/embree/device.h"
#include "engine/accel/embree/fat_triangles.h"
#include "engine/accel/embree/float_ray.h"
#include "engine/accel/embree/impl.h"
#include "engine/accel/embree/packets.h"
#include "engine/accel/embree/user_geometry.h"
#include "engine/accel/linear_accel.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine {

namespace embree {
namespace {

/// Estimated Embree footprint per primitive (BVH nodes + leaves): 90 B per triangle, from a
/// measured 85.5 MB for the BVH of 1M triangles (docs/loading.md); user-geometry leaves are
/// smaller.
constexpr std::size_t kBytesPerTriangle = 90;
constexpr std::size_t kBytesPerUserPrimitive = 64;

// ---------------------------------------------------------------------------------------------
// The builds.

/// fast's float triangles as they are, their vertices and indices carved from `buffer`
/// (released once the BVH is built: embree/build_buffer.h); null where it has no room.
GeometryHandle make_triangle_geometry(RTCDevice device, const TriangleMesh& mesh, const Impl& a,
                                      BuildBuffer& buffer) {
    GeometryHandle g(rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE));
    float* v;
    unsigned* idx;
    if (!share_triangle_buffers(g.get(), buffer, mesh.positions.size(), mesh.triangles.size(), v,
                                idx))
        return nullptr;
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
        const Vec3d q = a.frame(mesh.positions[i]);
        // to_float, should a coordinate exceed float's range all the same.
        v[3 * i + 0] = to_float(q.x);
        v[3 * i + 1] = to_float(q.y);
        v[3 * i + 2] = to_float(q.z);
    }
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
        idx[3 * i + 0] = mesh.triangles[i][0];
        idx[3 * i + 1] = mesh.triangles[i][1];
        idx[3 * i + 2] = mesh.triangles[i][2];
    }
    return g;
}

/// Bytes of a BuildBuffer make_triangle_geometry carves for `mesh`.
std::size_t triangle_geometry_bytes(const TriangleMesh& mesh) {
    return triangle_buffer_bytes(mesh.positions.size(), mesh.triangles.size());
}

/// One BuildBuffer for the geometries of every mesh of `scene`, `bytes(mesh)` each: one mapping
/// a scene (embree/build_buffer.h).
BuildBuffer buffer_for_meshes(const Scene& scene, std::size_t (*bytes)(const TriangleMesh&)) {
    std::size_t total = 0;
    for (const Object& o : scene.objects)
        if (o.kind != ObjectKind::sphere)
            total += bytes(*o.mesh);
    return BuildBuffer(total);
}

}  // namespace

void Impl::set_frame(const Bounds3& b) {
    if (b.empty())
        return;
    // Padding of the exact BVH's boxes: the float ray differs from the double one by the
    // rounding of its origin (inside the bounds, relative to their centre, so ≤ u_f·diagonal)
    // and of its unit direction (≤ u_f per component, times at most the diagonal along the
    // segment); boxes round outward. 8·u_f·(2·diagonal) covers all three with room to spare.
    center = b.center();
    float_scale = 2.0 * scaled_length(b.diagonal()) + 1e-300;
    pad = 8.0 * kFloatUnitRoundoff * float_scale + 1e-300;
    unit = power_to_unit(float_scale);
    padded_bounds = b;
    padded_bounds.lo -= Vec3d{pad, pad, pad} * 2.0;
    padded_bounds.hi += Vec3d{pad, pad, pad} * 2.0;
    for (std::size_t k = 0; k < 3; ++k) {
        padded_bounds_rel.lo[k] = next_down(padded_bounds.lo[k] - center[k]);
        padded_bounds_rel.hi[k] = next_up(padded_bounds.hi[k] - center[k]);
    }
}

void Impl::build_exact() const {
    exact_status = exact.build(*this);  // written once, under call_once, before any query reads it
    exact_ready = exact_status.ok();    // counted in memory_bytes once it exists
}

void Impl::build_fast() const {
    // fast is Embree's plain float traversal, what a program of one's own calling rtcIntersect
    // gets, and its speed is the point of asking for it: without ROBUST it is 10-20% faster on
    // random rays (bench_intersect's "ROBUST" rows). The price is leaks through shared edges and
    // vertices (docs/accuracy.md counts them). refined keeps the ROBUST scene, whose triangles
    // are widened (fat_triangles.h): fast's are the float triangles as they are, in geometries
    // of their own; the spheres' user geometries are shared (an Embree geometry may be attached
    // to several scenes).
    RTCDevice device = shared_device();
    take_error("");
    SceneHandle s(rtcNewScene(device));
    fast_buffer = buffer_for_meshes(*scene, triangle_geometry_bytes);
    for (std::uint32_t i = 0; i < scene->objects.size(); ++i) {
        const Object& o = scene->objects[i];
        if (o.kind == ObjectKind::sphere) {
            rtcAttachGeometryByID(s.get(), rtcGetGeometry(native.get(), i), i);
            continue;
        }
        const GeometryHandle g = make_triangle_geometry(device, *o.mesh, *this, fast_buffer);
        if (!g) {
            fast_status =
                Status::error(Code::too_large, "out of memory for the fast BVH's triangles");
            s.reset();  // the scene, and the geometries sharing the buffer, before the buffer
            fast_buffer = BuildBuffer();
            return;  // fast's queries trace native
        }
        rtcCommitGeometry(g.get());
        rtcAttachGeometryByID(s.get(), g.get(), i);
    }
    rtcCommitScene(s.get());
    fast_status = take_error("building the fast BVH");
    if (fast_status.ok() && can_release_built_buffers(device)) {
        // A BVH of Triangle4 leaves (neither ROBUST nor COMPACT), which hold copies of the
        // vertices as the Triangle4v leaves of native do (embree/build_buffer.h).
        fast_buffer.release();
    }
    fast = std::move(s);  // written once, under call_once, before any query reads it
    fast_ready = fast_status.ok();
}

namespace {

/// The sphere hit the native traversal's callback decided in double and kept, with its normal.
/// (sphere_hits' normal, which knows which root it is: recomputed from t alone, a root just
/// past tmin whose neighbour rounds next to it could take the other side: a helper's review.)
Hit kept_sphere_hit(const std::optional<Hit>& sphere_hit, bool want_normal) {
    Hit h = *sphere_hit;
    if (!want_normal)
        h.normal = Vec3d{};  // sphere_hits fills it for front_face: not asked, not answered
    return h;
}

// ---------------------------------------------------------------------------------------------
// exact (embree_accel.h). Where the exact BVH could not be built the linear scan answers: still
// exact. A ray whose origin is far from the scene (RayContext::far: ~1e8 scene sizes and
// beyond) is moved along its line to the scene first (move_near_scene) and answered there, in
// the centre's frame (RayFrame::centre); its answers are mapped back (moved_back). Until
// 2026-12-05 the double kernels decided on the far ray itself, wrong by up to ~u·distance (a
// line through a point a third of the way inside a triangle, from 1e18 away, missed it at
// exact), and from ~1e16 on the linear scan answered (1.6 ms a ray on a 69k-triangle mesh: a
// body of such rays kept the server busy for minutes). Where the move is not possible the ray
// is answered as it is: the exact BVH, or the scan where the float ray cannot be placed.

/// The first stage of Woop's test for the walk of exact's BVH to pre-test triangles with
/// (ExactBvh::closest): `woop`, formed for c's ray, where that ray is in the scene's own
/// coordinates; none for a far ray moved into the centre's frame (RayContext::frame), whose
/// triangles the double tests translate first.
const WoopRay* walk_pretest(const RayContext& c, const WoopRay& woop) {
    return c.frame ? nullptr : &woop;
}

/// The hit of the moved ray `m` as the client's ray's (far_ray.h's moved_back).
void moved_back(const Impl& a, const MovedRay& m, Hit& h) {
    engine::moved_back(*a.scene, m, h);
}

std::optional<Hit> exact_closest_placed(const Impl& a, const ExactBvh& bvh, bool want_normal,
                                        RayContext& c, const FloatRay& f, FarSpheres* far,
                                        const WoopRay* formed = nullptr);

/// `far`, with RayFrame::centre: `ray` is the far ray far->client moved to the scene
/// (far->moved), and the answer is mapped back to the client's ray (spheres decided on it).
std::optional<Hit> exact_closest(const Impl& a, const Ray& ray, bool want_normal,
                                 RayFrame frame = RayFrame::world, FarSpheres* far = nullptr) {
    RayContext c(a);
    const ExactBvh* bvh = a.exact_bvh();
    if (!bvh)
        return linear_closest(*a.scene, ray, want_normal);
    // Not for a far ray moved to the scene: its triangles are translated into the centre's
    // frame, and the answer's normal is the triangle's own (formed below).
    c.want_normal = want_normal && frame == RayFrame::world;
    FloatRay f;
    if (!prepare_ray(a, ray, RayStart::backed_off, c, f, frame))
        return std::nullopt;
    if (c.far && frame == RayFrame::world) {
        MovedRay m;
        switch (move_near_scene(a, ray, m)) {
            case MoveResult::misses:
                return std::nullopt;
            case MoveResult::moved: {
                FarSpheres spheres(ray, m);
                return exact_closest(a, m.ray, want_normal, RayFrame::centre, &spheres);
            }
            case MoveResult::not_possible:
                break;
        }
    }
    // (A moved ray starts two scene radii away: always within the padding. Should it not be, the
    // scan answers the client's ray, not the moved one, which is relative to the centre.)
    if (!exact_ray_within_padding(a, c))
        return linear_closest(*a.scene, far ? *far->client : ray, want_normal);
    return exact_closest_placed(a, *bvh, want_normal, c, f, far);
}

std::optional<Hit> exact_closest_answer(const Impl& a, bool want_normal, RayContext& c,
                                        FarSpheres* far);

/// exact_closest once prepare_ray has placed the float ray `f` (context `c`) within the
/// padding: the walk and the answer. `formed`: woop_ray(*c.ray), where the caller has formed it.
std::optional<Hit> exact_closest_placed(const Impl& a, const ExactBvh& bvh, bool want_normal,
                                        RayContext& c, const FloatRay& f, FarSpheres* far,
                                        const WoopRay* formed) {
    c.far_spheres = far;
    WoopRay woop;
    if (!formed) {
        woop = woop_ray(*c.ray);
        formed = &woop;
    }
    bvh.closest(
        f,
        [&c](std::uint32_t object, std::uint32_t prim, float& tfar) {
            keep_candidates(c, object, prim, tfar);  // the closest in c.best
            return true;
        },
        walk_pretest(c, *formed));
    return exact_closest_answer(a, want_normal, c, far);
}

/// The answer of a walk of exact's BVH that left its closest candidate in c.best.
std::optional<Hit> exact_closest_answer(const Impl& a, bool want_normal, RayContext& c,
                                        FarSpheres* far) {
    if (!c.best)
        return std::nullopt;
    if (far && far->best) {  // a sphere's, decided on the client's ray, with its normal
        Hit h = *far->best;
        if (!want_normal)
            h.normal = Vec3d{};
        return h;
    }
    Hit h = *c.best;
    if (want_normal) {
        const Object& o = a.scene->objects[h.object];
        // A sphere's came with the candidate (sphere_hits), a triangle's too where the
        // context asked for it (RayContext::want_normal).
        if (o.kind != ObjectKind::sphere && !c.want_normal)
            h.normal = triangle_normal(o.mesh->triangle(h.primitive));
    } else {
        h.normal = Vec3d{};  // a sphere's candidate came with one (sphere_hits)
    }
    if (far) {
        moved_back(a, *far->moved, h);
        // Its t overflowed double on the way back, and every other candidate lies beyond it: no
        // hit (sphere.h, first_root_in_range).
        if (!std::isfinite(h.t))
            return std::nullopt;
    }
    return h;
}

/// exact_closest of rays[0..n) into out[0..n): sixteen rays at a time, those prepare_ray would
/// place within the padding set up four at a time in AVX's registers (backed_off_lanes_avx: the
/// same bits), the others by exact_closest itself. One ray at a time, prepare_ray and its slab
/// test had taken 347 instructions a ray of A's camera rays; the batch of 1M such rays, the
/// exact BVH's build included, went from 3,612 to 3,333 M (callgrind; wall clock the same within
/// the host's noise).
void exact_closest_range(const Impl& a, const Ray* rays, std::size_t n, bool want_normal,
                         Hit* out) {
    const ExactBvh* bvh = a.exact_bvh();
    if (!bvh || widest_fast_lanes() != FastLanes::avx) {
        for (std::size_t i = 0; i < n; ++i) {
            auto h = exact_closest(a, rays[i], want_normal);
            out[i] = h ? *h : Hit{};
        }
        return;
    }
    for (std::size_t i = 0; i < n; i += kLanes) {
        const std::size_t m = std::min(kLanes, n - i);
        RayContext lanes[kLanes];
        alignas(64) RTCRay16 r16;
        alignas(64) int valid[kLanes];
        const unsigned left = backed_off_lanes_avx(a, rays + i, m, want_normal, lanes, r16, valid);
        // Each half's placed rays that run with its first (ExactBvh::runs_with: a camera's)
        // walk the tree together (ExactBvh::closest_packet); the others walk it alone.
        WoopRay woop[kLanes];
        unsigned alone = 0;
        for (std::size_t half = 0; half < m; half += ExactBvh::kWidth) {
            const std::size_t end = std::min(m, half + ExactBvh::kWidth);
            unsigned members = 0;
            std::size_t first = end;
            for (std::size_t k = half; k < end; ++k) {
                if ((left >> k & 1) || !valid[k])
                    continue;
                woop[k] = woop_ray(*lanes[k].ray);
                if (first == end) {
                    first = k;
                    members |= 1u << k;
                } else if (ExactBvh::runs_with(float_ray_of(r16, first), float_ray_of(r16, k))) {
                    members |= 1u << k;
                } else {
                    alone |= 1u << k;
                }
            }
            if (__builtin_popcount(members) < 2) {
                alone |= members;
                continue;
            }
            ExactBvh::Packet p{};  // lanes not added hold zeros, read and masked off
            for (unsigned on = members; on; on &= on - 1) {
                const std::size_t k = static_cast<std::size_t>(__builtin_ctz(on));
                ExactBvh::add_lane(p, static_cast<int>(k - half), float_ray_of(r16, k),
                                   walk_pretest(lanes[k], woop[k]));
            }
            bvh->closest_packet(p, [&](int lane, std::uint32_t object, std::uint32_t prim,
                                       float& tfar) {
                keep_candidates(lanes[half + static_cast<std::size_t>(lane)], object, prim, tfar);
                return true;
            });
            // Every member is answered (a closest visitor never ends a lane's walk early).
            for (unsigned on = members; on; on &= on - 1) {
                const auto k = static_cast<std::size_t>(__builtin_ctz(on));
                const std::optional<Hit> h =
                    exact_closest_answer(a, want_normal, lanes[k], nullptr);
                out[i + k] = h ? *h : Hit{};
            }
        }
        for (std::size_t k = 0; k < m; ++k) {
            const Ray& ray = rays[i + k];
            std::optional<Hit> h;
            if (left >> k & 1) {
                h = exact_closest(a, ray, want_normal);
            } else if (!valid[k]) {
                // the ray's segment misses the bounds
            } else if (alone >> k & 1) {
                h = exact_closest_placed(a, *bvh, want_normal, lanes[k], float_ray_of(r16, k),
                                         nullptr, &woop[k]);
            } else {
                continue;  // answered by its packet
            }
            out[i + k] = h ? *h : Hit{};
        }
    }
}

bool exact_any(const Impl& a, const Ray& ray, RayFrame frame = RayFrame::world,
               FarSpheres* far = nullptr) {
    RayContext c(a);
    const ExactBvh* bvh = a.exact_bvh();
    if (!bvh)
        return linear_any(*a.scene, ray);
    FloatRay f;
    if (!prepare_ray(a, ray, RayStart::backed_off, c, f, frame))
        return false;
    if (c.far && frame == RayFrame::world) {
        MovedRay m;
        switch (move_near_scene(a, ray, m)) {
            case MoveResult::misses:
                return false;
            case MoveResult::moved: {
                FarSpheres spheres(ray, m);
                return exact_any(a, m.ray, RayFrame::centre, &spheres);
            }
            case MoveResult::not_possible:
                break;
        }
    }
    if (!exact_ray_within_padding(a, c))
        return linear_any(*a.scene, far ? *far->client : ray);
    c.far_spheres = far;
    const WoopRay woop = woop_ray(*c.ray);
    bool hit = false;
    bvh->any(
        f,
        [&c, &hit](std::uint32_t object, std::uint32_t prim, float&) {
            hit = occludes(c, object, prim);
            return !hit;
        },
        walk_pretest(c, woop));
    return hit;
}

/// Every hit decided in double (refined's `all` too: counting crossings must not leak through
/// shared vertices, which Embree's float test occasionally does).
void exact_all(const Impl& a, const Ray& ray, bool want_normal, std::vector<Hit>& out,
               RayFrame frame = RayFrame::world, FarSpheres* far = nullptr) {
    RayContext c(a);
    c.collect = &out;
    const ExactBvh* bvh = a.exact_bvh();
    if (!bvh)
        return linear_all(*a.scene, ray, want_normal, out);
    FloatRay f;
    if (!prepare_ray(a, ray, RayStart::backed_off, c, f, frame))
        return;
    if (c.far && frame == RayFrame::world) {
        MovedRay m;
        switch (move_near_scene(a, ray, m)) {
            case MoveResult::misses:
                return;
            case MoveResult::moved: {
                FarSpheres spheres(ray, m);
                exact_all(a, m.ray, want_normal, out, RayFrame::centre, &spheres);
                return;
            }
            case MoveResult::not_possible:
                break;
        }
    }
    if (!exact_ray_within_padding(a, c))
        return linear_all(*a.scene, far ? *far->client : ray, want_normal, out);
    c.far_spheres = far;
    // Every candidate goes to c.collect (a far ray's spheres' to far->hits).
    const WoopRay woop = woop_ray(*c.ray);
    bvh->any(
        f,
        [&c](std::uint32_t object, std::uint32_t prim, float& tfar) {
            keep_candidates(c, object, prim, tfar);
            return true;
        },
        walk_pretest(c, woop));
    // Triangles' moved crossings, and then spheres', in the moved ray's frame, for the order.
    std::vector<Hit> moved;
    if (far) {
        moved = out;
        moved.insert(moved.end(), far->hits_moved.begin(), far->hits_moved.end());
        for (Hit& h : out)
            moved_back(a, *far->moved, h);
        out.insert(out.end(), far->hits.begin(), far->hits.end());
    }
    for (Hit& h : out) {
        const Object& o = a.scene->objects[h.object];
        if (want_normal && o.kind != ObjectKind::sphere) {
            h.normal = triangle_normal(o.mesh->triangle(h.primitive));
        } else if (!want_normal) {
            h.normal = Vec3d{};  // a sphere's hits came with one (sphere_hits)
        }
    }
    if (far)
        sort_and_merge_on_moved(moved, out);  // along the moved ray (far_ray.h)
    else
        sort_and_merge_edge_duplicates(out);  // by `closer` on the client's t
}

// ---------------------------------------------------------------------------------------------
// fast (embree_accel.h): a float miss is taken as it is.

/// fast's answer from what the native traversal found (sphere_hit: the sphere callback's hit).
std::optional<Hit> fast_answer(const Impl& a, const Ray& ray, const RayContext& c,
                               const NativeHit& nh, bool want_normal) {
    if (unplaced(c))
        return exact_closest(a, ray, want_normal);  // not traced in float (prepare_ray)
    if (nh.geom == RTC_INVALID_GEOMETRY_ID)
        return std::nullopt;
    const Object& o = a.scene->objects[nh.geom];
    if (o.kind == ObjectKind::sphere)
        return kept_sphere_hit(c.best, want_normal);
    Hit h;
    fast_hit(a, ray, c.shift, c.len, nh, want_normal, h);
    // A far ray's shift (its distance over its direction's length) can overflow double where its
    // float crossing is fine: no hit, as in the kernels (sphere.h, first_root_in_range).
    if (!std::isfinite(h.t))
        return std::nullopt;
    return h;
}

std::optional<Hit> fast_closest(const Impl& a, const Ray& ray, bool want_normal) {
    RayContext c(a);
    FloatRay f;
    if (!prepare_fast_native_ray(a, ray, c, f))
        return std::nullopt;
    const RTCRayHit rh = intersect1(a.fast_scene(), c, f);
    return fast_answer(a, ray, c, native_hit(rh, 0), want_normal);
}

bool fast_any(const Impl& a, const Ray& ray) {
    RayContext c(a);
    RTCScene s = a.fast_scene();
    FloatRay f;
    if (!prepare_fast_native_ray(a, ray, c, f))
        return false;
    if (unplaced(c))
        return exact_any(a, ray);  // not traced in float (prepare_ray)
    return occluded1(s, c, f);
}

/// Every hit on the ROBUST BVH (fast's own would leak more): its fat triangles' candidates are
/// decided in double by their hit filter (fat_triangles.cpp), the spheres by fast's kernel.
void fast_all(const Impl& a, const Ray& ray, bool want_normal, std::vector<Hit>& out) {
    RayContext c(a);
    c.collect = &out;
    FloatRay f;
    if (!prepare_ray(a, ray, RayStart::backed_off, c, f))
        return;
    // Not traced in float (unplaced), or far: the filter would decide on the far ray itself,
    // within ~u·distance (a helper's probe: a crossing dropped from 1e15 away); exact moves it.
    if (c.far)
        return exact_all(a, ray, want_normal, out);
    c.fast = true;
    intersect1(a.native.get(), c, f);  // every double hit goes to c.collect
    for (Hit& h : out) {
        const Object& o = a.scene->objects[h.object];
        if (want_normal && o.kind != ObjectKind::sphere)
            h.normal = triangle_normal(o.mesh->triangle(h.primitive));
        else if (!want_normal)
            h.normal = Vec3d{};  // a sphere's hits came with one (sphere_hits)
    }
    sort_and_merge_edge_duplicates(out);
}

/// Groups of 16 rays of a triangle-only scene go through Embree's packets: coherent groups
/// (camera rays) win most, 2.6-3.9x; random rays still gain 4-11% over single rays
/// (bench_intersect's rtcIntersect16 rows), so every full group goes as a packet, flagged
/// coherent or not. Packets carry only Embree's own triangles: user geometry (spheres) is
/// traced one ray at a time.
bool packets_apply(const Impl& a, std::size_t m) {
    return a.spheres == 0 && m >= 4;
}

void fast_closest_range(const Impl& a, const Ray* rays, std::size_t n, bool want_normal, Hit* out) {
    for (std::size_t i = 0; i < n; i += kLanes) {
        const std::size_t m = std::min(kLanes, n - i);
        if (!packets_apply(a, m)) {
            for (std::size_t k = 0; k < m; ++k) {
                auto h = fast_closest(a, rays[i + k], want_normal);
                out[i + k] = h ? *h : Hit{};
            }
            continue;
        }
        RTCScene s = a.fast_scene();
        // fast_packet hands Embree a plain context, which only fast's own BVH may see: where it
        // could not be built, fast_scene() is the native BVH, whose hit filter reads a
        // RayContext (found by a helper's review; closest_packet below gives each lane one).
        if (s != a.native.get() && fast_packet(a, s, rays + i, m, want_normal, out + i))
            continue;
        closest_packet(
            a, s, rays + i, m,
            [&](const Ray& ray, RayContext& c, FloatRay& f) {
                return prepare_fast_native_ray(a, ray, c, f);
            },
            [&](std::size_t k, const RayContext& c, const NativeHit& nh) {
                return fast_answer(a, rays[i + k], c, nh, want_normal);
            },
            out + i);
    }
}

void fast_any_range(const Impl& a, const Ray* rays, std::size_t n, std::uint8_t* out) {
    for (std::size_t i = 0; i < n; i += kLanes) {
        const std::size_t m = std::min(kLanes, n - i);
        if (!packets_apply(a, m)) {
            for (std::size_t k = 0; k < m; ++k)
                out[i + k] = fast_any(a, rays[i + k]) ? 1 : 0;
            continue;
        }
        RTCScene s = a.fast_scene();
        // Only fast's own BVH takes a plain context (fast_closest_range says why).
        if (s != a.native.get() && fast_any_packet(a, s, rays + i, m, out + i))
            continue;
        any_packet(
            a, s, rays + i, m,
            [&](const Ray& ray, RayContext& c, FloatRay& f) {
                return prepare_fast_native_ray(a, ray, c, f);
            },
            [&](std::size_t k, const RayContext& c) {
                return unplaced(c) && exact_any(a, rays[i + k]);  // not traced in float
            },
            out + i);
    }
}

// ---------------------------------------------------------------------------------------------
// refined (embree_accel.h). One traversal of the native BVH, whose fat triangles' candidates
// the hit filter decides in double (fat_triangles.h): a double hit found there is refined's
// answer, and a float miss is a miss. The exact path decides instead, and the ray counts as
// escalated, where that argument does not hold: the filter rejected a candidate on the way (the
// ray passed within the widening of an edge), the float ray's start point is farther from the
// double one than the argument allows (a far origin), or the scene is not certified (a
// sliver); in such a scene a back face found first is re-decided too (a ray entering a closed
// mesh that slips through a vertex in float meets the exit face first).

/// refined confirms a float miss. Where the scene has no more than this many triangles, and
/// the ray is within the boxes' padding, it scans them instead of the exact BVH: the native
/// traversal already decided every sphere in double, so only a triangle can have been missed
/// (e.g. the ground plane of a scene of spheres, whose shadow rays mostly escape).
constexpr std::size_t kConfirmByScanMaxTriangles = 16;

bool can_confirm_by_scan(const Impl& a, const RayContext& c) {
    return a.triangles <= kConfirmByScanMaxTriangles && exact_ray_within_padding(a, c);
}

/// Whether a float miss of the ray set up in `c` on the native BVH is a miss (see above).
bool miss_is_certain(const Impl& a, const RayContext& c) {
    return a.certified_misses && !c.rejected() && exact_ray_within_padding(a, c);
}

/// Whether the back face c.best may be refined's answer in a certified scene where the filter
/// rejected nothing: crossed at sin β ≥ 1/16 at least 2Δ/sin β + 2Δ from its triangle's edges
/// (Δ = 2 pads, the float line's displacement; crossed_well_inside, fat_triangles.h). The float
/// line's crossing of the face's float triangle then lies more than Δ inside that triangle, not
/// in its widening: it genuinely leaves the float solid there, so it was inside just before,
/// and a float ray that started outside the float solid crossed into it earlier, which the
/// watertight traversal reports as a candidate (a closer front face, or a rejection). What it
/// rules out: a ray that clips a ridge less deeply than Δ, so that the float line passes
/// outside; it enters through a face at a grazing angle the widening does not cover and leaves
/// near the shared edge through the neighbour, whose widened triangle reports the exit (the
/// differential fuzzer, seed 703669: a level-2 icosphere, entry at β = 0.33°, the exit 5e-11
/// from the edge, tests/stress/regressions/refined-leak-clipping-a-ridge.txt). What it assumes:
/// the float ray starts outside the float solid whenever the double ray does, which fails only
/// for an origin within ~Δ of the surface (a ray spawned on it at a grazing angle).
bool exits_well_inside(const Impl& a, const RayContext& c) {
    const Hit& h = *c.best;
    return crossed_well_inside(a.scene->objects[h.object].mesh->triangle(h.primitive), h.u, h.v,
                               c.ray->direction, 2.0 * a.pad);
}

/// Whether the hit c.best found on the native BVH set up in `c` is refined's answer: the filter
/// rejected nothing before it (a candidate rejected at the same crossing, within the float
/// ray's margin, is the neighbour of the triangle hit there), and a back face only in a
/// certified scene, after no rejection at all, crossed well inside (exits_well_inside). A back
/// face first otherwise goes to the exact path: the ray may have slipped in through an edge
/// (found by the fuzzer on a ray grazing an icosahedron at 0.015°,
/// tests/stress/regressions/triangle-t-259-ulps.txt) or clipped a ridge (above).
bool rejected_before_best(const RayContext& c) {
    return static_cast<double>(c.rejected_tf) < static_cast<double>(c.best_tf) - c.margin;
}
bool hit_is_certain(const Impl& a, const RayContext& c) {
    if (c.best->front_face)
        return !rejected_before_best(c);
    return a.certified_misses && !c.rejected() && exits_well_inside(a, c);
}

/// The closest triangle hit, every triangle of the scene tested in double (spheres skipped:
/// only the triangle objects are visited, so a scene of 1,000 spheres and a floor scans one).
std::optional<Hit> closest_triangle_scan(const Impl& a, const Ray& ray, bool want_normal) {
    std::optional<Hit> best;
    for (const std::uint32_t i : a.triangle_objects) {
        auto h = linear_closest_in_object(*a.scene, i, ray, want_normal);
        if (h && (!best || closer(*h, *best)))
            best = h;
    }
    return best;
}

/// refined's answer from a traversal of the native BVH set up in `c` (c.best: the double hit
/// its callbacks accepted); `escalated` is set when the exact path had to decide.
std::optional<Hit> refined_answer(const Impl& a, const Ray& ray, const RayContext& c,
                                  bool want_normal, bool& escalated) {
    if (c.far) {
        // The filter decided on the far ray itself, within ~u·distance: exact moves it.
        escalated = true;
        return exact_closest(a, ray, want_normal);
    }
    if (c.best) {
        const Object& o = a.scene->objects[c.best->object];
        if (o.kind == ObjectKind::sphere && !rejected_before_best(c))
            return kept_sphere_hit(c.best, want_normal);
        if (o.kind != ObjectKind::sphere && hit_is_certain(a, c)) {
            Hit h = *c.best;
            if (want_normal && !c.want_normal)  // else the hit filter gave it (RayContext)
                h.normal = triangle_normal(o.mesh->triangle(h.primitive));
            return h;
        }
    } else if (miss_is_certain(a, c)) {
        return std::nullopt;
    } else if (can_confirm_by_scan(a, c)) {
        return closest_triangle_scan(a, ray, want_normal);
    }
    escalated = true;
    return exact_closest(a, ray, want_normal);
}

/// refined's float ray: started a margin before the segment (as the exact BVH's), so that a
/// candidate at exactly tmin lies inside it; the hit filter's double test enforces the range.
bool prepare_refined_ray(const Impl& a, const Ray& ray, RayContext& c, FloatRay& f) {
    return prepare_ray(a, ray, RayStart::backed_off, c, f);
}

/// prepare_refined_ray for a closest query whose answer wants the normal, which the hit filter
/// then gives each double hit (RayContext::want_normal).
bool prepare_refined_closest_ray(const Impl& a, const Ray& ray, bool want_normal, RayContext& c,
                                 FloatRay& f) {
    c.want_normal = want_normal;
    return prepare_refined_ray(a, ray, c, f);
}

std::optional<Hit> refined_closest(const Impl& a, const Ray& ray, bool want_normal,
                                   bool& escalated) {
    RayContext c(a);
    FloatRay f;
    if (!prepare_refined_closest_ray(a, ray, want_normal, c, f))
        return std::nullopt;
    intersect1(a.native.get(), c, f);
    return refined_answer(a, ray, c, want_normal, escalated);
}

/// refined's `any` after the native occlusion query found nothing.
bool refined_confirm_no_hit(const Impl& a, const Ray& ray, const RayContext& c) {
    if (c.far)
        return exact_any(a, ray);  // moved to the scene (refined_answer)
    if (miss_is_certain(a, c))
        return false;
    if (can_confirm_by_scan(a, c))
        return closest_triangle_scan(a, ray, false).has_value();
    return exact_any(a, ray);
}

bool refined_any(const Impl& a, const Ray& ray) {
    RayContext c(a);
    FloatRay f;
    if (!prepare_refined_ray(a, ray, c, f))
        return false;
    if (c.far)
        return exact_any(a, ray);  // a hit the filter decided on the far ray is not trusted
    if (occluded1(a.native.get(), c, f))
        return true;
    return refined_confirm_no_hit(a, ray, c);
}

// In a scene that is not certified, a refined ray in doubt pays both traversals, plus the
// double recompute, and random rays mostly are (73% of bench_intersect's incoherent rays miss).
// So there, once a group of 16 had a ray escalate, the next group goes to the exact path
// directly, which answers refined's question at least as well in one traversal; that group's
// answers say whether to switch back. Measured on workload A's incoherent rays before the fat
// triangles (bench_intersect --modes closest --precisions refined): switching at > 1/2, > 1/8
// and > 0 of a group escalated gave 1.7, 2.0 and 4.0 Mrays/s, with camera rays unchanged
// (10.2). In a certified scene escalations are rare (rays within the widening of a silhouette
// that miss) and every group takes the native BVH. The groups are fixed by the caller's blocks
// (QueryEngine::kBlockRays), so the choice, and hence the answer to a near-tie, does not depend
// on the threads.

void refined_closest_range(const Impl& a, const Ray* rays, std::size_t n, bool want_normal,
                           Hit* out) {
    bool exact_first = false;
    for (std::size_t i = 0; i < n; i += kLanes) {
        const std::size_t m = std::min(kLanes, n - i);
        int escalations = 0;
        if (exact_first) {
            for (std::size_t k = 0; k < m; ++k) {
                const Ray& ray = rays[i + k];
                auto h = exact_closest(a, ray, want_normal);
                out[i + k] = h ? *h : Hit{};
                // What refined would have escalated: a back face, or a miss inside the bounds.
                if (out[i + k].valid() ? !out[i + k].front_face : enters_bounds(a, ray))
                    ++escalations;
            }
        } else if (!packets_apply(a, m)) {
            for (std::size_t k = 0; k < m; ++k) {
                bool escalated = false;
                auto h = refined_closest(a, rays[i + k], want_normal, escalated);
                out[i + k] = h ? *h : Hit{};
                escalations += escalated;
            }
        } else {
            const auto prepare = [&](const Ray& ray, RayContext& c, FloatRay& f) {
                return prepare_refined_closest_ray(a, ray, want_normal, c, f);
            };
            closest_packet_filled(
                a, a.native.get(), rays + i, m,
                [&](RayContext* lanes, RTCRay16& r16, int* valid) {
                    fill_backed_off_lanes(a, rays + i, m, want_normal, prepare, lanes, r16, valid);
                },
                [&](std::size_t k, const RayContext& c, const NativeHit&) {
                    bool escalated = false;
                    // A far lane goes to the exact path either way (refined_answer).
                    auto h = c.retrace && !c.far
                                 ? refined_closest(a, rays[i + k], want_normal, escalated)
                                 : refined_answer(a, rays[i + k], c, want_normal, escalated);
                    escalations += escalated;
                    return h;
                },
                out + i, /*defer=*/true);
        }
        exact_first = !a.certified_misses && escalations > 0;
    }
}

/// Whether a ray of the group may have an origin prepare_ray marks far (maybe_far).
bool group_maybe_far(const Impl& a, const Ray* rays, std::size_t m) {
    for (std::size_t k = 0; k < m; ++k) {
        if (maybe_far(a, rays[k]))
            return true;
    }
    return false;
}

void refined_any_range(const Impl& a, const Ray* rays, std::size_t n, std::uint8_t* out) {
    bool exact_first = false;
    for (std::size_t i = 0; i < n; i += kLanes) {
        const std::size_t m = std::min(kLanes, n - i);
        int escalations = 0;
        // A packet reports a lane's hit as the filter decided it; a far ray's (decided on the
        // ray itself) is not refined's answer, so a group with one goes ray by ray.
        if (exact_first || !packets_apply(a, m) || group_maybe_far(a, rays + i, m)) {
            for (std::size_t k = 0; k < m; ++k) {
                const Ray& ray = rays[i + k];
                const bool hit = exact_first ? exact_any(a, ray) : refined_any(a, ray);
                out[i + k] = hit ? 1 : 0;
                if (!hit && enters_bounds(a, ray))
                    ++escalations;
            }
        } else {
            const auto prepare = [&](const Ray& ray, RayContext& c, FloatRay& f) {
                return prepare_refined_ray(a, ray, c, f);
            };
            any_packet_filled(
                a, a.native.get(), rays + i, m,
                [&](RayContext* lanes, RTCRay16& r16, int* valid) {
                    fill_backed_off_lanes(a, rays + i, m, /*want_normal=*/false, prepare, lanes,
                                          r16, valid);
                },
                [&](std::size_t k, const RayContext& c) {
                    escalations += !miss_is_certain(a, c);
                    return refined_confirm_no_hit(a, rays[i + k], c);
                },
                out + i);
        }
        exact_first = !a.certified_misses && escalations > 0;
    }
}

}  // namespace
}  // namespace embree

// ---------------------------------------------------------------------------------------------
// The accelerator: the build, and each query handed to its precision's function.

EmbreeAccel::EmbreeAccel(std::unique_ptr<embree::Impl> impl) : impl_(std::move(impl)) {}
EmbreeAccel::~EmbreeAccel() = default;

Result<std::unique_ptr<EmbreeAccel>> EmbreeAccel::build(const Scene& scene,
                                                        const CancelToken& cancel) {
    RTCDevice device = embree::shared_device();
    if (!device)
        return Status::error(Code::internal, "cannot create the Embree device");
    auto impl = std::make_unique<embree::Impl>();
    impl->scene = &scene;
    impl->geoms.reserve(scene.objects.size());

    impl->set_frame(scene.bounds());

    embree::take_error("");  // start clean on this thread
    impl->native.reset(rtcNewScene(device));
    // ROBUST: Embree's watertight traversal and triangle test over refined's widened triangles
    // (embree/fat_triangles.h; also fast's all and count). Without it the widened triangles
    // passed the stress suites too, but rays aimed at edges were rejected, and so re-decided,
    // more often (docs/numerics.md). fast's closest and any trace a non-robust BVH of the
    // unwidened triangles (build_fast).
    rtcSetSceneFlags(impl->native.get(), RTC_SCENE_FLAG_ROBUST);
    const double widen_by = embree::kWidenPads * impl->pad;
    impl->native_buffer = embree::buffer_for_meshes(scene, embree::fat_triangle_bytes);
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        const Object& o = scene.objects[i];
        impl->geoms.push_back(embree::GeomData{impl.get(), i});
        embree::GeometryHandle g;
        if (o.kind == ObjectKind::sphere) {
            g = embree::make_user_geometry(device, &impl->geoms.back(), 1);
            ++impl->spheres;
        } else {
            bool capped = false;
            g = embree::make_fat_triangle_geometry(
                device, *o.mesh, *impl, widen_by, &impl->geoms.back(), capped, impl->native_buffer);
            if (!g)
                return Status::error(Code::too_large, "out of memory for the BVH's triangles");
            impl->certified_misses = impl->certified_misses && !capped;
            impl->triangles += o.mesh->size();
            impl->triangle_objects.push_back(i);
        }
        rtcCommitGeometry(g.get());
        rtcAttachGeometryByID(impl->native.get(), g.get(), i);  // geomID == object index
    }
    if (cancel.can_fire()) {
        // Embree asks this from its build threads as the build goes on; false stops it
        // (RTC_ERROR_CANCELLED).
        rtcSetSceneProgressMonitorFunction(
            impl->native.get(),
            [](void* token, double) {
                return !static_cast<const CancelToken*>(token)->cancelled();
            },
            const_cast<CancelToken*>(&cancel));
    }
    rtcCommitScene(impl->native.get());
    if (cancel.can_fire())  // the token is the caller's: nothing may ask it after the build
        rtcSetSceneProgressMonitorFunction(impl->native.get(), nullptr, nullptr);
    Status st = embree::take_error("building the BVH");
    if (cancel.fired())
        return cancel.status();
    if (!st.ok())
        return st;
    if (embree::can_release_built_buffers(device))  // Embree's leaves hold copies (build_buffer.h)
        impl->native_buffer.release();
    return std::unique_ptr<EmbreeAccel>(new EmbreeAccel(std::move(impl)));
}

std::optional<Hit> EmbreeAccel::closest(const Ray& ray, Precision precision,
                                        bool want_normal) const {
    switch (precision) {
        case Precision::fast:
            return embree::fast_closest(*impl_, ray, want_normal);
        case Precision::refined: {
            bool escalated = false;
            return embree::refined_closest(*impl_, ray, want_normal, escalated);
        }
        case Precision::exact:
            return embree::exact_closest(*impl_, ray, want_normal);
    }
    return std::nullopt;
}

void EmbreeAccel::closest_range(const Ray* rays, std::size_t n, Precision precision,
                                bool want_normal, Hit* out) const {
    switch (precision) {
        case Precision::fast:
            return embree::fast_closest_range(*impl_, rays, n, want_normal, out);
        case Precision::refined:
            return embree::refined_closest_range(*impl_, rays, n, want_normal, out);
        case Precision::exact:
            return embree::exact_closest_range(*impl_, rays, n, want_normal, out);
    }
}

bool EmbreeAccel::any(const Ray& ray, Precision precision) const {
    switch (precision) {
        case Precision::fast:
            return embree::fast_any(*impl_, ray);
        case Precision::refined:
            // A scene that is not certified confirms every float miss on the exact BVH, and
            // most shadow rays reach their light: the exact path is then one traversal instead
            // of two for an unblocked ray, with an answer at least as good.
            return impl_->certified_misses ? embree::refined_any(*impl_, ray)
                                           : embree::exact_any(*impl_, ray);
        case Precision::exact:
            return embree::exact_any(*impl_, ray);
    }
    return false;
}

void EmbreeAccel::any_range(const Ray* rays, std::size_t n, Precision precision,
                            std::uint8_t* out) const {
    switch (precision) {
        case Precision::fast:
            return embree::fast_any_range(*impl_, rays, n, out);
        case Precision::refined:
            return embree::refined_any_range(*impl_, rays, n, out);
        case Precision::exact:
            for (std::size_t i = 0; i < n; ++i)
                out[i] = embree::exact_any(*impl_, rays[i]) ? 1 : 0;
            return;
    }
}

void EmbreeAccel::all(const Ray& ray, Precision precision, bool want_normal,
                      std::vector<Hit>& out) const {
    out.clear();
    switch (precision) {
        case Precision::fast:
            return embree::fast_all(*impl_, ray, want_normal, out);
        case Precision::refined:  // counts on the exact path: see exact_all
        case Precision::exact:
            return embree::exact_all(*impl_, ray, want_normal, out);
    }
}

FloatFrame EmbreeAccel::float_frame() const {
    return FloatFrame{impl_->center, impl_->float_scale};
}

std::size_t EmbreeAccel::memory_bytes() const {
    const embree::Impl& a = *impl_;
    std::size_t bytes =
        a.triangles * embree::kBytesPerTriangle + a.spheres * embree::kBytesPerUserPrimitive;
    bytes += a.native_buffer.resident_bytes();  // none once released
    if (a.exact_ready)
        bytes += a.exact.memory_bytes();
    if (a.fast_ready) {  // its own BVH (over native's sphere geometries, shared)
        bytes +=
            a.triangles * embree::kBytesPerTriangle + a.spheres * embree::kBytesPerUserPrimitive;
        bytes += a.fast_buffer.resident_bytes();  // none once released
    }
    return bytes;
}

}  // namespace raycastd::engine
