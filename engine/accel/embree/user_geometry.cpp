#include "engine/accel/embree/user_geometry.h"

#include <algorithm>

#include "engine/accel/embree/float_ray.h"
#include "engine/accel/embree/impl.h"

namespace raycastd::engine::embree {

namespace {

/// Candidates of one primitive decided in double: the sphere roots in range, or the triangle
/// hit of the watertight test. `emit(h, client)` returns false to stop; `client` is null, or for
/// a sphere of a far ray's FarSpheres the hit on the client's ray, `h` then being it at its t on
/// the moved ray.
/// In a context with a frame (a far ray moved to the scene, given relative to the centre) each
/// primitive is translated by it first: the same difference the kernels form, a − o, up to the
/// rounding of a − centre (exact where they lie within a factor of two, Sterbenz).
/// `decision_only` (an occlusion query): a triangle's hit may carry Woop's t instead of the
/// plane crossing (decide_triangle), the same decision.
template <class F>
void double_candidates(const RayContext& c, std::uint32_t object, std::uint32_t prim, F&& emit,
                       bool decision_only = false) {
    const Object& o = c.accel->scene->objects[object];
    const Ray& ray = *c.ray;
    if (o.kind == ObjectKind::sphere) {
        Hit hits[2];
        if (const FarSpheres* far = c.far_spheres) {
            // Decided on the client's ray; ordered among the other candidates by the roots on
            // the moved ray, whose t' keep the sphere's place along the line to a few u of the
            // scene (the client's t, rounded at ~u·distance, would not: a sphere in front of a
            // mesh, both 1e18 away, came after it). Where the two kernels disagree on the count
            // (a line within the move's error of tangency, or of a range's end) the sphere is
            // placed at the moved ray's closest approach to its centre (sphere_on_moved). (The
            // client's root carried over, rounded by ~u·distance, had put a sphere behind a cube
            // 3e-3 beyond it in 64 of 1,000 such lines from 2^50–2^56 away: a helper's review.)
            const int n = sphere_hits(o.sphere, *far->client, hits);
            if (n == 0)
                return;
            Hit on_moved[2];
            const Sphere in_frame = c.in_frame(o.sphere);
            const int n_moved = sphere_hits(in_frame, ray, on_moved);
            for (int k = 0; k < n; ++k) {
                hits[k].object = object;
                const Hit moved =
                    sphere_on_moved(in_frame, *far->moved, ray, hits[k], k, n, on_moved, n_moved);
                if (!emit(moved, &hits[k]))
                    return;
            }
            return;
        }
        const Sphere s = c.in_frame(o.sphere);
        const int n = c.fast ? sphere_hits_fast(s, ray, hits) : sphere_hits(s, ray, hits);
        for (int k = 0; k < n; ++k) {
            hits[k].object = object;
            if (!emit(hits[k], nullptr))
                return;
        }
        return;
    }
    const Triangle tri = c.in_frame(o.mesh->triangle(prim));
    // The normal with the hit where the caller wants it (RayContext::want_normal).
    if (auto h = decision_only ? decide_triangle(tri, ray)
                               : intersect_triangle(tri, ray, c.want_normal)) {
        h->object = object;
        h->primitive = prim;
        emit(*h, nullptr);
    }
}

}  // namespace

FloatBox primitive_box(const Impl& a, const Object& o, std::uint32_t prim) {
    Bounds3 b;
    if (o.kind == ObjectKind::sphere) {
        b = object_bounds(o);  // rounded outward: a radius below an ulp of the centre counts
    } else {
        const Triangle t = o.mesh->triangle(prim);
        b.extend(t.a);
        b.extend(t.b);
        b.extend(t.c);
    }
    const double p = a.pad;
    b.lo -= a.center;
    b.hi -= a.center;
    const double u = a.unit;  // Embree's frame: exact scaling
    FloatBox out;
    for (int k = 0; k < 3; ++k) {
        out.lo[k] = float_down((b.lo[k] - p) * u);
        out.hi[k] = float_up((b.hi[k] + p) * u);
    }
    return out;
}

void keep_candidates(RayContext& c, std::uint32_t object, std::uint32_t prim, float& tfar) {
    double_candidates(c, object, prim, [&](const Hit& h, const Hit* client) {
        if (c.collect) {
            if (client) {
                c.far_spheres->hits.push_back(*client);
                c.far_spheres->hits_moved.push_back(h);
            } else {
                c.collect->push_back(h);
            }
            return true;
        }
        if (!c.best || closer(h, *c.best)) {
            c.best = h;
            if (c.far_spheres)
                c.far_spheres->best = client ? std::optional<Hit>(*client) : std::nullopt;
            tfar = std::min(tfar, tfar_for(c, h.t));
        }
        return true;
    });
}

bool occludes(const RayContext& c, std::uint32_t object, std::uint32_t prim) {
    bool hit = false;
    double_candidates(
        c, object, prim,
        [&](const Hit&, const Hit*) {
            hit = true;
            return false;
        },
        /*decision_only=*/true);
    return hit;
}

namespace {

void user_bounds(const RTCBoundsFunctionArguments* args) {
    const auto* g = static_cast<const GeomData*>(args->geometryUserPtr);
    const FloatBox b = primitive_box(*g->accel, g->accel->scene->objects[g->object], args->primID);
    RTCBounds* out = args->bounds_o;
    out->lower_x = b.lo[0];
    out->lower_y = b.lo[1];
    out->lower_z = b.lo[2];
    out->upper_x = b.hi[0];
    out->upper_y = b.hi[1];
    out->upper_z = b.hi[2];
}

/// A sphere of a native BVH: collected (all, count), or offered to refined's and fast's closest
/// within Embree's float tfar.
void user_intersect(const RTCIntersectFunctionNArguments* args) {
    if (!args->valid[0])
        return;
    const auto* g = static_cast<const GeomData*>(args->geometryUserPtr);
    RayContext& c = ctx_of(args->context);
    auto* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);  // N == 1: we only call rtcIntersect1
    if (c.collect) {
        float tfar = rh->ray.tfar;  // collecting lowers nothing
        keep_candidates(c, g->object, args->primID, tfar);
        return;
    }
    double_candidates(c, g->object, args->primID, [&](const Hit& h, const Hit*) {
        // A sphere is offered within Embree's float tfar, as a triangle is, and competes with
        // the best so far in double (keep_if_closer).
        const float tf = to_float((h.t - c.shift) * c.len);
        if (!(tf <= rh->ray.tfar))
            return true;
        float tfar = tf;
        if (keep_if_closer(c, h, tf, tfar)) {
            rh->ray.tfar = std::min(rh->ray.tfar, tfar);
            rh->hit.geomID = h.object;
            rh->hit.primID = h.primitive;
            rh->hit.u = rh->hit.v = 0.0f;
        }
        return false;  // the nearer root came first: the far one cannot come before it
    });
}

void user_occluded(const RTCOccludedFunctionNArguments* args) {
    if (!args->valid[0])
        return;
    const auto* g = static_cast<const GeomData*>(args->geometryUserPtr);
    if (occludes(ctx_of(args->context), g->object, args->primID))
        reinterpret_cast<RTCRay*>(args->ray)->tfar =
            -std::numeric_limits<float>::infinity();  // Embree's "occluded" signal
}

}  // namespace

GeometryHandle make_user_geometry(RTCDevice device, GeomData* data, unsigned prims) {
    GeometryHandle g(rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER));
    rtcSetGeometryUserPrimitiveCount(g.get(), prims);
    rtcSetGeometryUserData(g.get(), data);
    rtcSetGeometryBoundsFunction(g.get(), user_bounds, nullptr);
    rtcSetGeometryIntersectFunction(g.get(), user_intersect);
    rtcSetGeometryOccludedFunction(g.get(), user_occluded);
    return g;
}

}  // namespace raycastd::engine::embree
