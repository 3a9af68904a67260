#include "engine/accel/embree_accel.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>

#include <embree3/rtcore.h>

#include "engine/accel/linear_accel.h"
#include "engine/math/double_double.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine {

namespace {

// ---------------------------------------------------------------------------------------------
// The device: one per process, created on first use. Embree reports errors through a callback;
// we record the last one per thread so that a build turns it into a Status (nothing is printed).

thread_local RTCError t_last_error = RTC_ERROR_NONE;
thread_local std::string t_last_message;

void on_embree_error(void*, RTCError code, const char* message) {
    t_last_error = code;
    t_last_message = message ? message : "";
}

RTCDevice shared_device() {
    static RTCDevice device = [] {
        RTCDevice d = rtcNewDevice("verbose=0");
        if (d)
            rtcSetDeviceErrorFunction(d, on_embree_error, nullptr);
        return d;
    }();
    return device;
}

Status take_embree_error(const char* what) {
    const RTCError e = t_last_error;
    const std::string msg = t_last_message;
    t_last_error = RTC_ERROR_NONE;
    t_last_message.clear();
    if (e == RTC_ERROR_NONE)
        return {};
    const Code code = e == RTC_ERROR_OUT_OF_MEMORY ? Code::too_large : Code::internal;
    return Status::error(code, std::string(what) + ": Embree error " +
                                   std::to_string(static_cast<int>(e)) +
                                   (msg.empty() ? "" : " (" + msg + ")"));
}

/// v as a float, ±infinity beyond float's range (a plain conversion of a finite double above
/// FLT_MAX is undefined behaviour).
float to_float(double v) {
    constexpr double kMax = std::numeric_limits<float>::max();
    if (v > kMax)
        return std::numeric_limits<float>::infinity();
    if (v < -kMax)
        return -std::numeric_limits<float>::infinity();
    return static_cast<float>(v);
}

float float_down(double v) {
    const float f = static_cast<float>(v);
    return static_cast<double>(f) > v ? std::nextafter(f, -std::numeric_limits<float>::infinity())
                                      : f;
}
float float_up(double v) {
    const float f = static_cast<float>(v);
    return static_cast<double>(f) < v ? std::nextafter(f, std::numeric_limits<float>::infinity())
                                      : f;
}

/// Estimated Embree footprint per primitive (BVH nodes + leaves), from the measurements in
/// PERFORMANCE.md (85.5 MB for 1M triangles); user-geometry leaves are smaller.
constexpr std::size_t kBytesPerTriangle = 90;
constexpr std::size_t kBytesPerUserPrimitive = 64;

}  // namespace

// ---------------------------------------------------------------------------------------------

/// What the callbacks of one geometry need: which object it is.
struct GeomData {
    const EmbreeAccel::Impl* accel;
    std::uint32_t object;
};

struct EmbreeAccel::Impl {
    const Scene* scene = nullptr;
    RTCScene native = nullptr;  ///< float triangles + sphere user geometry (fast, refined)
    /// The same geometries in a BVH without RTC_SCENE_FLAG_ROBUST, for fast's closest and any
    /// (see build_fast); built by the first such query.
    mutable RTCScene fast = nullptr;
    mutable std::atomic<bool> fast_ready{false};
    mutable std::once_flag fast_once;
    mutable Status fast_status;
    mutable RTCScene exact = nullptr;  ///< every primitive as user geometry, double tests
    mutable std::atomic<bool> exact_ready{false};
    mutable std::once_flag exact_once;
    mutable Status exact_status;
    std::vector<GeomData> geoms;  ///< one per object, stable addresses (reserved up front)
    Bounds3 padded_bounds;
    /// Embree sees every coordinate relative to this point (the centre of the scene bounds):
    /// float precision then follows the scene's size, not its distance from the origin.
    Vec3d center;
    double pad = 0;          ///< absolute padding of every box, in scene units (see build)
    double float_scale = 0;  ///< magnitude of scene coordinates, for the fast path's t_err
    std::size_t triangles = 0, spheres = 0;
    /// The objects that are triangles or meshes, in order (refined's scan of few triangles).
    std::vector<std::uint32_t> triangle_objects;

    ~Impl() {
        if (native)
            rtcReleaseScene(native);
        if (exact)
            rtcReleaseScene(exact);
        if (fast)
            rtcReleaseScene(fast);
    }
    void build_exact() const;
    void build_fast() const;
    /// The scene fast's closest and any trace: the non-robust one, or `native` if it could not
    /// be built.
    RTCScene fast_scene() const {
        std::call_once(fast_once, [this] { build_fast(); });
        return fast_status.ok() ? fast : native;
    }
    /// The float BVH a fast or refined query traverses: fast's own, or the ROBUST one.
    RTCScene float_scene(Precision p) const { return p == Precision::fast ? fast_scene() : native; }
    RTCScene exact_scene() const {
        std::call_once(exact_once, [this] { build_exact(); });
        return exact_status.ok() ? exact : nullptr;
    }
};

namespace {

/// The context handed through Embree to our callbacks (Embree's documented way to pass per-ray
/// data: a struct that starts with RTCIntersectContext).
struct RayContext {
    RTCIntersectContext rtc;
    const EmbreeAccel::Impl* accel = nullptr;
    const Ray* ray = nullptr;  ///< the double-precision ray
    double shift = 0;          ///< the float ray starts at ray.at(shift)
    double len = 1;            ///< |direction|: float t' (unit direction) ↔ t = shift + t'/len
    double margin = 0;         ///< slack added to tfar, in unit-direction length
    double origin_err = 0;     ///< bound on the double rounding of the float ray's start point
    std::optional<Hit> best;   ///< closest so far (exact path)
    std::vector<Hit>* collect = nullptr;  ///< all/count: every hit goes here
    bool exact = false;  ///< the exact BVH: candidates compete in double, not by float tfar
    bool fast = false;   ///< precision fast: spheres by the plain-double kernel
};

RayContext& ctx_of(RTCIntersectContext* c) {
    return *reinterpret_cast<RayContext*>(c);
}

/// tfar for a candidate at double t: never below it, whatever the float rounding.
float tfar_for(const RayContext& c, double t) {
    return float_up((t - c.shift) * c.len + c.margin);
}

/// Candidates of one primitive decided in double: the sphere roots in range, or the triangle
/// hit of the watertight test. `emit` returns false to stop.
template <class F>
void double_candidates(const RayContext& c, std::uint32_t object, std::uint32_t prim, F&& emit) {
    const Object& o = c.accel->scene->objects[object];
    const Ray& ray = *c.ray;
    if (o.kind == ObjectKind::sphere) {
        Hit hits[2];
        const int n =
            c.fast ? sphere_hits_fast(o.sphere, ray, hits) : sphere_hits(o.sphere, ray, hits);
        for (int k = 0; k < n; ++k) {
            hits[k].object = object;
            if (!emit(hits[k]))
                return;
        }
        return;
    }
    if (auto h = intersect_triangle(o.mesh->triangle(prim), ray, false)) {
        h->object = object;
        h->primitive = prim;
        emit(*h);
    }
}

void user_bounds(const RTCBoundsFunctionArguments* args) {
    const auto* g = static_cast<const GeomData*>(args->geometryUserPtr);
    const Object& o = g->accel->scene->objects[g->object];
    Bounds3 b;
    if (o.kind == ObjectKind::sphere) {
        const Vec3d r{o.sphere.radius, o.sphere.radius, o.sphere.radius};
        b.extend(o.sphere.center - r);
        b.extend(o.sphere.center + r);
    } else {
        const Triangle t = o.mesh->triangle(args->primID);
        b.extend(t.a);
        b.extend(t.b);
        b.extend(t.c);
    }
    const double p = g->accel->pad;
    b.lo -= g->accel->center;
    b.hi -= g->accel->center;
    RTCBounds* out = args->bounds_o;
    out->lower_x = float_down(b.lo.x - p);
    out->lower_y = float_down(b.lo.y - p);
    out->lower_z = float_down(b.lo.z - p);
    out->upper_x = float_up(b.hi.x + p);
    out->upper_y = float_up(b.hi.y + p);
    out->upper_z = float_up(b.hi.z + p);
}

void user_intersect(const RTCIntersectFunctionNArguments* args) {
    if (!args->valid[0])
        return;
    const auto* g = static_cast<const GeomData*>(args->geometryUserPtr);
    RayContext& c = ctx_of(args->context);
    auto* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);  // N == 1: we only call rtcIntersect1
    double_candidates(c, g->object, args->primID, [&](const Hit& h) {
        if (c.collect) {
            c.collect->push_back(h);
            return true;
        }
        if (c.exact) {
            if (!c.best || closer(h, *c.best)) {
                c.best = h;
                rh->ray.tfar = std::min(rh->ray.tfar, tfar_for(c, h.t));
                rh->hit.geomID = h.object;
                rh->hit.primID = h.primitive;
            }
            return true;
        }
        // The native BVH: a sphere competes with Embree's float triangle hits by float t'.
        const float tf = to_float((h.t - c.shift) * c.len);
        if (!(tf <= rh->ray.tfar))
            return true;
        rh->ray.tfar = tf;
        rh->hit.geomID = h.object;
        rh->hit.primID = h.primitive;
        rh->hit.u = rh->hit.v = 0.0f;
        c.best = h;
        return false;  // the nearer root came first: the far one cannot be closer
    });
}

void user_occluded(const RTCOccludedFunctionNArguments* args) {
    if (!args->valid[0])
        return;
    const auto* g = static_cast<const GeomData*>(args->geometryUserPtr);
    RayContext& c = ctx_of(args->context);
    auto* ray = reinterpret_cast<RTCRay*>(args->ray);
    double_candidates(c, g->object, args->primID, [&](const Hit&) {
        ray->tfar = -std::numeric_limits<float>::infinity();  // Embree's "occluded" signal
        return false;
    });
}

/// Context filter for `all` on native triangles: record the float hit, then reject it so the
/// traversal goes on to the next one.
void collect_filter(const RTCFilterFunctionNArguments* args) {
    RayContext& c = ctx_of(args->context);
    if (args->N != 1 || !args->valid[0] || !c.collect)
        return;
    const auto* hit = reinterpret_cast<const RTCHit*>(args->hit);
    const auto* ray = reinterpret_cast<const RTCRay*>(args->ray);
    if (c.accel->scene->objects[hit->geomID].kind == ObjectKind::sphere)
        return;  // user geom
    Hit h;
    h.object = hit->geomID;
    h.primitive = hit->primID;
    h.t = c.shift + static_cast<double>(ray->tfar) / c.len;
    h.u = hit->u;
    h.v = hit->v;
    c.collect->push_back(h);
    args->valid[0] = 0;
}

RTCGeometry make_user_geometry(RTCDevice device, GeomData* data, unsigned prims) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, prims);
    rtcSetGeometryUserData(g, data);
    rtcSetGeometryBoundsFunction(g, user_bounds, nullptr);
    rtcSetGeometryIntersectFunction(g, user_intersect);
    rtcSetGeometryOccludedFunction(g, user_occluded);
    return g;
}

RTCGeometry make_triangle_geometry(RTCDevice device, const TriangleMesh& mesh,
                                   const Vec3d& center) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.positions.size()));
    auto* idx = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                mesh.triangles.size()));
    if (!v || !idx)
        return g;  // the error callback has recorded why; commit reports it
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
        const Vec3d q = mesh.positions[i] - center;
        // to_float: a scene may be finite in double and still span more than float can hold
        // (±inf then, which Embree ignores; refined and exact decide such triangles in double).
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

/// Sets up the float ray for a double ray: it starts where the double ray enters the padded
/// scene bounds (or at tmin, if later), with a unit direction. False when the ray's segment
/// misses the bounds altogether, so nothing can be hit.
/// The part of the ray's segment [tmin, tmax] inside the padded scene bounds, [t0, t1]; false
/// when there is none.
bool clip_to_bounds(const EmbreeAccel::Impl& a, const Ray& ray, double& t0, double& t1) {
    // Slab test in double (Kay & Kajiya 1986) against the padded bounds.
    t0 = ray.tmin;
    t1 = ray.tmax;
    for (std::size_t k = 0; k < 3; ++k) {
        const double o = ray.origin[k], d = ray.direction[k];
        const double lo = a.padded_bounds.lo[k], hi = a.padded_bounds.hi[k];
        if (d == 0.0) {
            if (o < lo || o > hi)
                return false;
            continue;
        }
        double ta = (lo - o) / d, tb = (hi - o) / d;
        if (ta > tb)
            std::swap(ta, tb);
        // Widen by a few ulps: the divisions round, and a hit at the slab's edge must survive.
        t0 = std::max(t0, ta - gamma(3) * std::abs(ta));
        t1 = std::min(t1, tb + gamma(3) * std::abs(tb));
    }
    return t0 <= t1;
}

bool prepare_ray(const EmbreeAccel::Impl& a, const Ray& ray, bool back_off, RayContext& c,
                 RTCRay& r) {
    double t0, t1;
    if (!clip_to_bounds(a, ray, t0, t1))
        return false;
    c.ray = &ray;
    c.len = length(ray.direction);
    c.margin = 4.0 * a.pad;
    // The exact path backs the origin off by the padding so that a hit at exactly tmin lies
    // strictly inside the float segment; its double test still enforces tmin.
    c.shift = back_off ? t0 - c.margin / c.len : t0;
    // (o − centre) + s·d rather than (o + s·d) − centre: the first difference is exact or nearly
    // so when the origin is near the scene (Sterbenz), so the float origin is accurate to the
    // scene's size even when the scene sits far from the world origin. Its rounding is about
    // u·(|o − centre| + |s·d|): for an origin far from a small scene that exceeds the exact
    // BVH's box padding, and the start point is then formed in double-double instead (TwoSum
    // and TwoProduct are exact, their sum is off by a few u² of the terms: Ogita, Rump & Oishi
    // 2005), which keeps it within the padding out to ~1e15 scene sizes.
    const double far = length(ray.origin - a.center) + std::abs(c.shift) * c.len;
    Vec3d org;
    if (8.0 * kDoubleUnitRoundoff * far <= 0.25 * a.pad) {
        org = (ray.origin - a.center) + ray.direction * c.shift;
        c.origin_err = 8.0 * kDoubleUnitRoundoff * far;
    } else {
        for (std::size_t k = 0; k < 3; ++k) {
            const dd::DD p = dd::add(dd::two_sum(ray.origin[k], -a.center[k]),
                                     dd::two_prod(ray.direction[k], c.shift));
            org[k] = p.hi + p.lo;
        }
        // The double-double residual, then the rounding of the (near-scene) point to double.
        c.origin_err = 8.0 * kDoubleUnitRoundoff * kDoubleUnitRoundoff * far +
                       2.0 * kDoubleUnitRoundoff * length(org);
    }
    const Vec3d dir = ray.direction / c.len;
    r.org_x = to_float(org.x);  // inside the bounds, which may exceed float's range
    r.org_y = to_float(org.y);
    r.org_z = to_float(org.z);
    r.dir_x = static_cast<float>(dir.x);
    r.dir_y = static_cast<float>(dir.y);
    r.dir_z = static_cast<float>(dir.z);
    r.tnear = 0.0f;
    r.tfar = std::isinf(t1) ? std::numeric_limits<float>::infinity() : tfar_for(c, t1);
    r.time = 0.0f;
    r.mask = 0xFFFFFFFFu;  // Debian's Embree is built with ray masks: 0 would hit nothing
    r.id = 0;
    r.flags = 0;
    return true;
}

/// Whether prepare_ray_fast applies to `ray`, whose origin relative to the scene centre is org.
bool fast_ray_applies(const EmbreeAccel::Impl& a, const Ray& ray, const Vec3d& org) {
    const double d2 = dot(ray.direction, ray.direction);
    const double scale = a.float_scale;
    return ray.tmin >= 0.0 && dot(org, org) <= 16.0 * scale * scale && d2 >= 1e-12 && d2 <= 1e12;
}

/// The fast path's float ray: the double ray as it is, relative to the scene centre, with no
/// clipping to the bounds and no renormalisation (t comes back in the client's units). Used
/// when that loses nothing the float kernel had anyway: tmin ≥ 0, an origin within a few
/// scene sizes of the scene, and a direction of moderate length. Otherwise prepare_ray.
bool prepare_ray_fast(const EmbreeAccel::Impl& a, const Ray& ray, RayContext& c, RTCRay& r) {
    const Vec3d org = ray.origin - a.center;
    if (!fast_ray_applies(a, ray, org))
        return false;
    c.ray = &ray;
    c.shift = 0.0;
    c.len = 1.0;
    c.margin = 0.0;
    // Within 4 scene diagonals of the centre: in float's range, since wider scenes get no
    // Embree BVH (QueryEngine::build).
    r.org_x = static_cast<float>(org.x);
    r.org_y = static_cast<float>(org.y);
    r.org_z = static_cast<float>(org.z);
    r.dir_x = static_cast<float>(ray.direction.x);
    r.dir_y = static_cast<float>(ray.direction.y);
    r.dir_z = static_cast<float>(ray.direction.z);
    r.tnear = to_float(ray.tmin);
    r.tfar = to_float(ray.tmax);  // +inf stays +inf
    r.time = 0.0f;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
    return true;
}

/// Whether the float ray prepare_ray set up is within the exact BVH's box padding of the double
/// ray: its start point's double rounding (c.origin_err, plain or double-double) must stay
/// well inside the padding. Rays where it does not take the linear scan.
bool exact_ray_within_padding(const EmbreeAccel::Impl& a, const RayContext& c) {
    return c.origin_err <= 0.25 * a.pad;
}

/// fast's answer from Embree's float hit: t in the client's units (clamped to the range asked
/// for), a float-sized t_err, and Embree's float normal. Nothing of the double triangle is
/// read: that would cost a cache miss per ray (~15% of an incoherent batch) for digits fast
/// does not promise.
void fast_hit(const EmbreeAccel::Impl& a, const Ray& ray, double shift, double len, float tfar,
              unsigned geom, unsigned prim, float u, float v, const Vec3d& ng, bool want_normal,
              Hit& h) {
    h.t = std::min(std::max(shift + static_cast<double>(tfar) / len, ray.tmin), ray.tmax);
    // A float kernel: relative error of a few float ulps of the scene's coordinates.
    h.t_err =
        gamma_float(12) *
        ((a.float_scale + length(ray.origin - a.center)) / length(ray.direction) + std::abs(h.t));
    h.object = geom;
    h.primitive = prim;
    h.u = u;
    h.v = v;
    // Embree's Ng = (v2−v0)×(v0−v1) = (b−a)×(c−a) up to rounding: its sign gives the side.
    h.front_face = dot(ray.direction, ng) < 0.0;
    h.on_edge = false;
    if (want_normal) {
        const double l = length(ng);
        h.normal = l > 0.0 ? ng / l : Vec3d{};
    } else {
        h.normal = Vec3d{};
    }
}

/// refined confirms a float miss. Where the scene has no more than this many triangles, and
/// the ray is within the boxes' padding, it scans them instead of the exact BVH: the native
/// traversal already decided every sphere in double, so only a triangle can have been missed
/// (e.g. the ground plane of a scene of spheres, whose shadow rays mostly escape).
constexpr std::size_t kConfirmByScanMaxTriangles = 16;

bool can_confirm_by_scan(const EmbreeAccel::Impl& a, const RayContext& c) {
    return a.triangles <= kConfirmByScanMaxTriangles && exact_ray_within_padding(a, c);
}

/// The closest triangle hit, every triangle of the scene tested in double (spheres skipped:
/// only the triangle objects are visited, so a scene of 1,000 spheres and a floor scans one).
std::optional<Hit> closest_triangle_scan(const EmbreeAccel::Impl& a, const Ray& ray,
                                         bool want_normal) {
    std::optional<Hit> best;
    for (const std::uint32_t i : a.triangle_objects) {
        auto h = linear_closest_in_object(*a.scene, i, ray, want_normal);
        if (h && (!best || closer(*h, *best)))
            best = h;
    }
    return best;
}

/// prepare_ray_fast where it applies, else prepare_ray.
bool prepare_native_ray(const EmbreeAccel::Impl& a, const Ray& ray, Precision p, RayContext& c,
                        RTCRay& r) {
    c.fast = p == Precision::fast;
    // Spheres too: their callback works in the client's t units with shift 0 and len 1, and a
    // sphere culled by its box within the float rounding of the unclipped ray is within what
    // fast promises. Measured: clipping and normalising cost 17% of a fast render of spheres.
    if (p == Precision::fast && prepare_ray_fast(a, ray, c, r))
        return true;
    return prepare_ray(a, ray, /*back_off=*/false, c, r);
}

}  // namespace

// ---------------------------------------------------------------------------------------------

EmbreeAccel::EmbreeAccel(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
EmbreeAccel::~EmbreeAccel() = default;

Result<std::unique_ptr<EmbreeAccel>> EmbreeAccel::build(const Scene& scene) {
    RTCDevice device = shared_device();
    if (!device)
        return Status::error(Code::internal, "cannot create the Embree device");
    auto impl = std::make_unique<Impl>();
    impl->scene = &scene;
    impl->geoms.reserve(scene.objects.size());

    // Padding of the exact BVH's boxes: the float ray differs from the double one by the
    // rounding of its origin (inside the bounds, relative to their centre, so ≤ u_f·diagonal)
    // and of its unit direction (≤ u_f per component, times at most the diagonal along the
    // segment); boxes round outward. 8·u_f·(2·diagonal) covers all three with room to spare.
    const Bounds3 b = scene.bounds();
    if (!b.empty()) {
        impl->center = b.center();
        impl->float_scale = 2.0 * length(b.diagonal()) + 1e-300;
        impl->pad = 8.0 * kFloatUnitRoundoff * impl->float_scale + 1e-300;
        impl->padded_bounds = b;
        impl->padded_bounds.lo -= Vec3d{impl->pad, impl->pad, impl->pad} * 2.0;
        impl->padded_bounds.hi += Vec3d{impl->pad, impl->pad, impl->pad} * 2.0;
    }

    take_embree_error("");  // start clean on this thread
    impl->native = rtcNewScene(device);
    // ROBUST: Embree's watertight traversal and triangle test, for refined (and fast's all and
    // count). refined re-decides every float miss, but a float ray that leaks through an open
    // mesh can meet a farther front face, which it would accept (Fuzz.RegressionCases, with
    // this flag off). fast's closest and any trace a non-robust copy (build_fast).
    rtcSetSceneFlags(
        impl->native,
        static_cast<RTCSceneFlags>(RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION));
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        const Object& o = scene.objects[i];
        impl->geoms.push_back(GeomData{impl.get(), i});
        RTCGeometry g;
        if (o.kind == ObjectKind::sphere) {
            g = make_user_geometry(device, &impl->geoms.back(), 1);
            ++impl->spheres;
        } else {
            g = make_triangle_geometry(device, *o.mesh, impl->center);
            impl->triangles += o.mesh->size();
            impl->triangle_objects.push_back(i);
        }
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(impl->native, g, i);  // geomID == object index
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(impl->native);
    Status st = take_embree_error("building the BVH");
    if (!st.ok())
        return st;
    return std::unique_ptr<EmbreeAccel>(new EmbreeAccel(std::move(impl)));
}

void EmbreeAccel::Impl::build_exact() const {
    RTCDevice device = shared_device();
    take_embree_error("");
    RTCScene s = rtcNewScene(device);
    rtcSetSceneFlags(s, RTC_SCENE_FLAG_ROBUST);
    for (std::uint32_t i = 0; i < scene->objects.size(); ++i) {
        const Object& o = scene->objects[i];
        RTCGeometry g = make_user_geometry(device, const_cast<GeomData*>(&geoms[i]),
                                           static_cast<unsigned>(o.primitive_count()));
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(s, g, i);
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(s);
    exact_status = take_embree_error("building the exact BVH");
    exact = s;                        // written once, under call_once, before any query can read it
    exact_ready = exact_status.ok();  // counted in memory_bytes once it exists
}

void EmbreeAccel::Impl::build_fast() const {
    // fast is Embree's plain float traversal, what a program of one's own calling rtcIntersect
    // gets, and its speed is the point of asking for it: without ROBUST it is 10-20% faster on
    // random rays (bench_intersect's "ROBUST" rows). The price is leaks through shared edges and
    // vertices (docs/accuracy.md counts them). refined keeps the ROBUST scene: with this one it
    // took the far side of a leak through an open mesh for the answer (Fuzz.RegressionCases).
    // The geometries are shared, not copied (an Embree geometry may be attached to several
    // scenes); only the BVH is built again.
    RTCDevice device = shared_device();
    take_embree_error("");
    RTCScene s = rtcNewScene(device);
    for (std::uint32_t i = 0; i < scene->objects.size(); ++i)
        rtcAttachGeometryByID(s, rtcGetGeometry(native, i), i);
    rtcCommitScene(s);
    fast_status = take_embree_error("building the fast BVH");
    fast = s;  // written once, under call_once, before any query can read it
    fast_ready = fast_status.ok();
}

std::optional<Hit> EmbreeAccel::closest(const Ray& ray, Precision precision,
                                        bool want_normal) const {
    return closest_impl(ray, precision, want_normal, nullptr);
}

std::optional<Hit> EmbreeAccel::closest_impl(const Ray& ray, Precision precision, bool want_normal,
                                             bool* escalated) const {
    const Impl& a = *impl_;
    RayContext c;
    rtcInitIntersectContext(&c.rtc);
    c.accel = &a;
    RTCRayHit rh;
    if (precision == Precision::exact) {
        RTCScene s = a.exact_scene();
        if (!s)
            return linear_closest(*a.scene, ray, want_normal);  // could not build: still exact
        c.exact = true;
        if (!prepare_ray(a, ray, /*back_off=*/true, c, rh.ray))
            return std::nullopt;
        if (!exact_ray_within_padding(a, c))
            return linear_closest(*a.scene, ray, want_normal);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(s, &c.rtc, &rh);
        if (!c.best)
            return std::nullopt;
        Hit h = *c.best;
        if (want_normal) {
            const Object& o = a.scene->objects[h.object];
            if (o.kind == ObjectKind::sphere) {
                sphere_normal(o.sphere, ray, h.t, h);
            } else {
                h.normal = triangle_normal(o.mesh->triangle(h.primitive));
            }
        }
        return h;
    }

    if (!prepare_native_ray(a, ray, precision, c, rh.ray))
        return std::nullopt;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(a.float_scene(precision), &c.rtc, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID && precision == Precision::refined &&
        can_confirm_by_scan(a, c)) {
        return closest_triangle_scan(a, ray, want_normal);
    }
    NativeHit nh{rh.hit.geomID, rh.hit.primID, rh.ray.tfar,
                 rh.hit.u,      rh.hit.v,      Vec3d{rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z}};
    return finish_native(ray, c.shift, c.len, nh, c.best, precision, want_normal, escalated);
}

std::optional<Hit> EmbreeAccel::finish_native(const Ray& ray, double shift, double len,
                                              const NativeHit& nh,
                                              const std::optional<Hit>& sphere_hit,
                                              Precision precision, bool want_normal,
                                              bool* escalated) const {
    const Impl& a = *impl_;
    if (nh.geom == RTC_INVALID_GEOMETRY_ID) {
        // Embree's float test can let a ray through a shared vertex (measured: about 1 in 2,000
        // rays aimed exactly at vertices). refined promises no such leak, so a float miss is
        // confirmed by the exact traversal.
        if (precision != Precision::refined)
            return std::nullopt;
        if (escalated)
            *escalated = true;
        return closest(ray, Precision::exact, want_normal);
    }
    const std::uint32_t object = nh.geom;
    const Object& o = a.scene->objects[object];
    if (o.kind == ObjectKind::sphere) {
        // The sphere callback already decided in double and kept its hit.
        Hit h = *sphere_hit;
        if (want_normal)
            sphere_normal(o.sphere, ray, h.t, h);
        return h;
    }
    Hit h;
    if (precision != Precision::refined) {
        fast_hit(a, ray, shift, len, nh.tfar, object, nh.prim, nh.u, nh.v, nh.ng, want_normal, h);
        return h;
    }
    // refined: Embree chose the primitive; the hit on it is recomputed in double.
    // The exact path decides instead whenever the float choice is in doubt: the double
    // test misses the primitive (the ray passes at an edge, or float picked wrongly), or
    // the hit leaves a surface (a ray entering a closed mesh that slips through a vertex in
    // float meets the exit face first; rays that really start inside pay the exact path).
    auto d = intersect_triangle(o.mesh->triangle(nh.prim), ray, want_normal);
    if (!d || !d->front_face) {
        if (escalated)
            *escalated = true;
        return closest(ray, Precision::exact, want_normal);
    }
    h = *d;
    h.object = object;
    h.primitive = nh.prim;
    return h;
}

namespace {

/// Lane k of a 16-ray packet from rays[k] (prepare_native_ray): -1 (on), or 0 (off) for a lane
/// past m or a ray whose segment misses the scene's bounds.
int set_lane(const EmbreeAccel::Impl& a, const Ray* rays, std::size_t k, std::size_t m,
             Precision precision, RayContext& c, RTCRay16& r16) {
    RTCRay r{};
    c.accel = &a;
    const bool on = k < m && prepare_native_ray(a, rays[k], precision, c, r);
    r16.org_x[k] = r.org_x;
    r16.org_y[k] = r.org_y;
    r16.org_z[k] = r.org_z;
    r16.dir_x[k] = r.dir_x;
    r16.dir_y[k] = r.dir_y;
    r16.dir_z[k] = r.dir_z;
    r16.tnear[k] = r.tnear;
    r16.tfar[k] = on ? r.tfar : -1.0f;
    r16.time[k] = 0.0f;
    r16.mask[k] = 0xFFFFFFFFu;  // Debian's Embree is built with ray masks
    r16.id[k] = static_cast<unsigned>(k);
    r16.flags[k] = 0;
    return on ? -1 : 0;
}

/// Whether 16 rays are coherent enough for a packet: directions within ~10° of the first and
/// origins close together relative to the scene (camera rays, not random rays). Packets win
/// 2.6× on camera rays and lose on random ones (PERFORMANCE.md).
bool coherent(const Ray* rays, std::size_t n, double scene_scale) {
    // cos²(angle) ≥ 0.97 without square roots: (d·d0)² ≥ 0.97·|d|²·|d0|², d·d0 > 0.
    const Vec3d& d0 = rays[0].direction;
    const double d0d0 = dot(d0, d0);
    const double max_spread2 = 0.0025 * scene_scale * scene_scale;
    for (std::size_t i = 1; i < n; ++i) {
        const Vec3d& d = rays[i].direction;
        const double c = dot(d, d0);
        if (c <= 0.0 || c * c < 0.97 * dot(d, d) * d0d0)
            return false;
        const Vec3d o = rays[i].origin - rays[0].origin;
        if (dot(o, o) > max_spread2)
            return false;
    }
    return true;
}

/// The context of a packet of rays[0..m): flagged coherent when they are (coherent()).
RTCIntersectContext packet_context(const Ray* rays, std::size_t m, double scene_scale) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = coherent(rays, m, scene_scale) ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT
                                               : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    return ctx;
}

/// fast's packet of m (4 ≤ m ≤ 16) rays of a triangle-only scene when every one of them takes
/// prepare_ray_fast's float ray, i.e. almost always: t needs no shift or rescale, so the lanes
/// are filled straight from the double rays and the answers written straight from Embree's,
/// with no per-lane RayContext, no coherence test in double and no std::optional<Hit> in
/// between. That per-ray work was 40% of a camera-ray batch on B (perf: closest_range,
/// prepare_native_ray, finish_native, coherent), against 12% in raw Embree's own loop. False,
/// with nothing written, when some ray needs prepare_ray.
bool fast_packet(const EmbreeAccel::Impl& a, RTCScene scene, const Ray* rays, std::size_t m,
                 bool want_normal, Hit* out) {
    constexpr std::size_t kLanes = 16;
    alignas(64) RTCRayHit16 rh;
    alignas(64) int valid[kLanes];
    for (std::size_t k = 0; k < kLanes; ++k) {
        // Lanes past m repeat the last ray, switched off, so that the coherence test below
        // needs no mask.
        const Ray& ray = rays[std::min(k, m - 1)];
        const Vec3d org = ray.origin - a.center;
        if (!fast_ray_applies(a, ray, org))
            return false;
        rh.ray.org_x[k] = static_cast<float>(org.x);  // in range: see prepare_ray_fast
        rh.ray.org_y[k] = static_cast<float>(org.y);
        rh.ray.org_z[k] = static_cast<float>(org.z);
        rh.ray.dir_x[k] = static_cast<float>(ray.direction.x);
        rh.ray.dir_y[k] = static_cast<float>(ray.direction.y);
        rh.ray.dir_z[k] = static_cast<float>(ray.direction.z);
        rh.ray.tnear[k] = to_float(ray.tmin);
        rh.ray.tfar[k] = to_float(ray.tmax);
        rh.ray.time[k] = 0.0f;
        rh.ray.mask[k] = 0xFFFFFFFFu;  // Debian's Embree is built with ray masks
        rh.ray.id[k] = static_cast<unsigned>(k);
        rh.ray.flags[k] = 0;
        rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        valid[k] = k < m ? -1 : 0;
    }
    // coherent()'s test on the float lanes, without early exits so that it vectorises:
    // directions within ~10° of the first (cos² ≥ 0.97) and origins within 5% of the scene.
    const float d0x = rh.ray.dir_x[0], d0y = rh.ray.dir_y[0], d0z = rh.ray.dir_z[0];
    const float d0d0 = d0x * d0x + d0y * d0y + d0z * d0z;
    const float spread2 = to_float(0.0025 * a.float_scale * a.float_scale);  // may exceed FLT_MAX
    int incoherent = 0;
    for (std::size_t k = 1; k < kLanes; ++k) {
        const float dx = rh.ray.dir_x[k], dy = rh.ray.dir_y[k], dz = rh.ray.dir_z[k];
        const float c = dx * d0x + dy * d0y + dz * d0z;
        const float ox = rh.ray.org_x[k] - rh.ray.org_x[0];
        const float oy = rh.ray.org_y[k] - rh.ray.org_y[0];
        const float oz = rh.ray.org_z[k] - rh.ray.org_z[0];
        incoherent |= (c <= 0.0f) | (c * c < 0.97f * (dx * dx + dy * dy + dz * dz) * d0d0) |
                      (ox * ox + oy * oy + oz * oz > spread2);
    }
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags =
        incoherent ? RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT : RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    rtcIntersect16(valid, scene, &ctx, &rh);
    for (std::size_t k = 0; k < m; ++k) {
        if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) {
            out[k] = Hit{};  // fast takes a float miss as it is
            continue;
        }
        fast_hit(a, rays[k], 0.0, 1.0, rh.ray.tfar[k], rh.hit.geomID[k], rh.hit.primID[k],
                 rh.hit.u[k], rh.hit.v[k], Vec3d{rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]},
                 want_normal, out[k]);
    }
    return true;
}

}  // namespace

void EmbreeAccel::closest_range(const Ray* rays, std::size_t n, Precision precision,
                                bool want_normal, Hit* out) const {
    const Impl& a = *impl_;
    constexpr std::size_t kLanes = 16;
    // Packets carry only Embree's own triangles: user geometry (spheres, the exact BVH) is
    // traced one ray at a time. Coherent groups (camera rays) win most, 2.6-3.9x; random rays
    // still gain 4-11% over single rays (bench_intersect's rtcIntersect16 rows), so every full
    // group goes as a packet, flagged coherent or not.
    const bool packets = precision != Precision::exact && a.spheres == 0;
    // refined traces in float first and re-decides on the exact BVH when the float answer is in
    // doubt (a miss inside the bounds, a back face): such rays pay both traversals, plus the
    // double recompute. Random rays mostly do (73% of bench_intersect's incoherent rays miss).
    // So once a group of 16 had a ray escalate, the next group goes to the exact path directly,
    // which answers refined's question at least as well in one traversal; that group's answers
    // say whether to switch back. Measured on A incoherent (bench_intersect --modes closest
    // --precisions refined): switching at > 1/2, > 1/8 and > 0 of a group escalated gave
    // 1.7, 2.0 and 4.0 Mrays/s, with camera rays unchanged (10.2).
    bool exact_first = false;
    std::size_t i = 0;
    while (i < n) {
        const std::size_t m = std::min(kLanes, n - i);
        int escalations = 0;
        const auto count_escalation = [&](const Ray& ray, const Hit& h) {
            if (h.valid() ? !h.front_face : enters_bounds(ray))
                ++escalations;
        };
        if (precision == Precision::refined && exact_first) {
            for (std::size_t k = 0; k < m; ++k) {
                auto h = closest(rays[i + k], Precision::exact, want_normal);
                out[i + k] = h ? *h : Hit{};
                count_escalation(rays[i + k], out[i + k]);
            }
            exact_first = escalations > 0;
            i += m;
            continue;
        }
        if (packets && m >= 4 && precision == Precision::fast &&
            fast_packet(a, a.fast_scene(), rays + i, m, want_normal, out + i)) {
            i += m;
            continue;
        }
        if (!packets || m < 4) {
            for (std::size_t k = 0; k < m; ++k) {
                bool escalated = false;
                auto h = closest_impl(rays[i + k], precision, want_normal, &escalated);
                out[i + k] = h ? *h : Hit{};
                escalations += escalated;
            }
            exact_first = escalations > 0;
            i += m;
            continue;
        }
        RayContext lanes[kLanes];
        alignas(64) RTCRayHit16 rh;
        alignas(64) int valid[kLanes];
        for (std::size_t k = 0; k < kLanes; ++k) {
            valid[k] = set_lane(a, rays + i, k, m, precision, lanes[k], rh.ray);
            rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        }
        RTCIntersectContext ctx = packet_context(rays + i, m, a.float_scale);
        rtcIntersect16(valid, a.float_scene(precision), &ctx, &rh);
        for (std::size_t k = 0; k < m; ++k) {
            const Ray& ray = rays[i + k];
            if (!valid[k]) {
                // The segment misses the scene's bounds: nothing can be hit.
                out[i + k] = Hit{};
                continue;
            }
            NativeHit nh{rh.hit.geomID[k], rh.hit.primID[k],
                         rh.ray.tfar[k],   rh.hit.u[k],
                         rh.hit.v[k],      Vec3d{rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]}};
            bool escalated = false;
            auto h = finish_native(ray, lanes[k].shift, lanes[k].len, nh, std::nullopt, precision,
                                   want_normal, &escalated);
            out[i + k] = h ? *h : Hit{};
            escalations += escalated;
        }
        exact_first = escalations > 0;
        i += m;
    }
}

void EmbreeAccel::any_range(const Ray* rays, std::size_t n, Precision precision, Hit* out) const {
    const Impl& a = *impl_;
    constexpr std::size_t kLanes = 16;
    // As closest_range: groups of 16 triangle-only rays go through Embree's occlusion packets
    // (rtcOccluded16: 1.4-1.7x rtcOccluded1 on random rays, 2.8-4.6x on camera rays), and
    // refined, whose float misses inside the bounds must be confirmed on the exact BVH, sends
    // the next group there directly once a group needed it.
    const bool packets = precision != Precision::exact && a.spheres == 0;
    const auto answer = [](bool hit, Hit& h) {
        h = Hit{};
        if (hit)
            h.object = 0;  // `any` says only whether something is hit
    };
    bool exact_first = false;
    std::size_t i = 0;
    while (i < n) {
        const std::size_t m = std::min(kLanes, n - i);
        int escalations = 0;
        if (precision == Precision::exact || (precision == Precision::refined && exact_first) ||
            !packets || m < 4) {
            const Precision p = exact_first ? Precision::exact : precision;
            for (std::size_t k = 0; k < m; ++k) {
                const bool hit = any(rays[i + k], p);
                answer(hit, out[i + k]);
                if (!hit && precision == Precision::refined && enters_bounds(rays[i + k]))
                    ++escalations;
            }
            exact_first = escalations > 0;
            i += m;
            continue;
        }
        RayContext lanes[kLanes];
        alignas(64) RTCRay16 r16;
        alignas(64) int valid[kLanes];
        for (std::size_t k = 0; k < kLanes; ++k)
            valid[k] = set_lane(a, rays + i, k, m, precision, lanes[k], r16);
        RTCIntersectContext ctx = packet_context(rays + i, m, a.float_scale);
        rtcOccluded16(valid, a.float_scene(precision), &ctx, &r16);
        for (std::size_t k = 0; k < m; ++k) {
            bool hit = valid[k] && r16.tfar[k] == -std::numeric_limits<float>::infinity();
            if (valid[k] && !hit && precision == Precision::refined) {
                hit = any(rays[i + k], Precision::exact);
                ++escalations;
            }
            answer(hit, out[i + k]);
        }
        exact_first = escalations > 0;
        i += m;
    }
}

bool EmbreeAccel::enters_bounds(const Ray& ray) const {
    double t0, t1;
    return clip_to_bounds(*impl_, ray, t0, t1);
}

bool EmbreeAccel::any(const Ray& ray, Precision precision) const {
    const Impl& a = *impl_;
    RayContext c;
    rtcInitIntersectContext(&c.rtc);
    c.accel = &a;
    RTCScene s = a.float_scene(precision);
    if (precision == Precision::exact) {
        s = a.exact_scene();
        if (!s)
            return linear_any(*a.scene, ray);
    }
    RTCRay r;
    const bool prepared = precision == Precision::exact
                              ? prepare_ray(a, ray, /*back_off=*/true, c, r)
                              : prepare_native_ray(a, ray, precision, c, r);
    if (!prepared)
        return false;
    if (precision == Precision::exact && !exact_ray_within_padding(a, c)) {
        return linear_any(*a.scene, ray);
    }
    rtcOccluded1(s, &c.rtc, &r);
    const bool hit = r.tfar == -std::numeric_limits<float>::infinity();
    // As in closest: a float miss is confirmed before refined says so.
    if (!hit && precision == Precision::refined) {
        if (can_confirm_by_scan(a, c))
            return closest_triangle_scan(a, ray, false).has_value();
        return any(ray, Precision::exact);
    }
    return hit;
}

void EmbreeAccel::all(const Ray& ray, Precision precision, bool want_normal,
                      std::vector<Hit>& out) const {
    out.clear();
    const Impl& a = *impl_;
    RayContext c;
    rtcInitIntersectContext(&c.rtc);
    c.accel = &a;
    c.collect = &out;
    RTCRayHit rh;
    // Counting crossings must not leak through shared vertices, which Embree's float test
    // occasionally does: refined counts on the exact path. fast shows what float gives.
    if (precision != Precision::fast) {
        RTCScene s = a.exact_scene();
        if (!s)
            return linear_all(*a.scene, ray, want_normal, out);
        c.exact = true;
        if (!prepare_ray(a, ray, /*back_off=*/true, c, rh.ray))
            return;
        if (!exact_ray_within_padding(a, c))
            return linear_all(*a.scene, ray, want_normal, out);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(s, &c.rtc, &rh);
        for (Hit& h : out) {
            const Object& o = a.scene->objects[h.object];
            if (want_normal && o.kind != ObjectKind::sphere) {
                h.normal = triangle_normal(o.mesh->triangle(h.primitive));
            }
        }
        sort_and_merge_edge_duplicates(out);
        return;
    }
    if (!prepare_ray(a, ray, /*back_off=*/false, c, rh.ray))
        return;
    c.fast = true;
    c.rtc.filter = collect_filter;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(a.native, &c.rtc, &rh);
    // Float hits on triangles are recomputed in double. Which triangles of a shared edge the
    // float test reports is its own business, so "on an edge" is judged with a float-sized
    // tolerance on the barycentrics, and such hits of one object that agree in t merge.
    constexpr double kEdgeTolerance = 1e-5;
    for (Hit& h : out) {
        const Object& o = a.scene->objects[h.object];
        if (o.kind == ObjectKind::sphere)
            continue;
        const Triangle tri = o.mesh->triangle(h.primitive);
        const double fu = h.u, fv = h.v;
        auto d = triangle_plane_hit(tri, ray, want_normal);
        if (d) {
            const std::uint32_t object = h.object, prim = h.primitive;
            h = *d;
            h.object = object;
            h.primitive = prim;
        }
        h.on_edge = fu <= kEdgeTolerance || fv <= kEdgeTolerance || 1.0 - fu - fv <= kEdgeTolerance;
        h.t_err = std::max(h.t_err, gamma_float(12) * (a.float_scale / c.len + std::abs(h.t)));
    }
    sort_and_merge_edge_duplicates(out);
}

std::size_t EmbreeAccel::memory_bytes() const {
    const Impl& a = *impl_;
    std::size_t bytes =
        a.triangles * (kBytesPerTriangle + 12 * sizeof(float)) + a.spheres * kBytesPerUserPrimitive;
    if (a.exact_ready)
        bytes += (a.triangles + a.spheres) * kBytesPerUserPrimitive;
    if (a.fast_ready)
        bytes += a.triangles * kBytesPerTriangle + a.spheres * kBytesPerUserPrimitive;
    return bytes;
}

}  // namespace raycastd::engine
