#include "engine/accel/embree/fat_triangles.h"

#include <algorithm>
#include <cmath>

#include "engine/accel/embree/float_ray.h"
#include "engine/accel/embree/impl.h"
#include "engine/geometry/triangle_lanes.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine::embree {

namespace {

thread_local DeferralCounts t_deferral_counts;

/// The mesh of `lane`'s deferred candidate.
const TriangleMesh& pending_mesh(const RayContext& lane) {
    const GeomData& g = *lane.pending_geom;
    return *g.accel->scene->objects[g.object].mesh;
}

/// The deferred candidate of `lane` (RayContext::pending_geom) decided as decide() would have
/// decided it when Embree offered it: a double hit away from its triangle's edges becomes the
/// lane's best, exactly as keep_if_closer makes the first hit of a lane, with tfar left at its
/// float t, which is what Embree did when it accepted the candidate undecided. Anything else
/// (a double miss, which decide() rejects and Embree would then have traced on beyond it; a hit
/// near an edge, whose tfar keep_if_closer raises) would have changed the traversal, and
/// returns false: the lane must be traced again (RayContext::retrace).
bool settle_pending(RayContext& lane) {
    // A pending candidate is only ever made on a lane without a best, and every other decision
    // on the lane settles it first (ready_to_decide). Spheres' callbacks would not: packets are
    // traced only in scenes without spheres (packets_apply, embree_accel.cpp).
    const GeomData& g = *lane.pending_geom;
    const Triangle tri = pending_mesh(lane).triangle(lane.pending_prim);
    lane.pending_geom = nullptr;
    LineCrossing outside;
    auto h = intersect_triangle(tri, *lane.ray, lane.want_normal, &outside);
    if (!h || near_edge(*h))
        return false;
    h->object = g.object;
    h->primitive = lane.pending_prim;
    lane.best = *h;
    lane.best_tf = lane.pending_tf;
    return true;
}

/// Before a candidate of a deferring packet's lane is decided: settles the lane's pending
/// candidate first (it came earlier, and decide() would have decided it then). Returns false
/// where the lane is to be traced again, whose candidates are then all accepted undecided (its
/// traversal shortens; its answer comes from the second traversal).
bool ready_to_decide(RayContext& lane) {
    if (lane.retrace)
        return false;
    if (lane.pending_geom && !settle_pending(lane)) {
        lane.retrace = true;
        ++t_deferral_counts.retraced;
        return false;
    }
    return true;
}

/// What decide() does with one lane's double answer `h` on triangle `tri` (primitive `prim`).
void settle(const RTCFilterFunctionNArguments* args, unsigned i, RayContext& lane,
            const GeomData& g, unsigned prim, const Triangle& tri, std::optional<Hit>& h,
            const LineCrossing& outside, bool occlusion) {
    // Embree set tfar to the candidate's float t; keep_if_closer may move it.
    float& tfar = RTCRayN_tfar(args->ray, args->N, i);
    const float tf = tfar;
    if (!h) {
        args->valid[i] = 0;
        // Only where the candidate would be offered with tfar at best_tf: one seen beyond
        // it because keep_if_closer leaves tfar above (a neighbour's widening just behind
        // the hit) is not evidence that the ray slipped in before the hit, and counting
        // it would send every back face with such a neighbour to the exact path.
        // Nor is a crossing outside [tmin, tmax] well inside the triangle
        // (outside_range_well_inside): a spawned ray's own triangle, behind its origin.
        if ((!lane.best || tf <= lane.best_tf) &&
            !outside_range_well_inside(tri, outside, *lane.ray, 2.0 * g.accel->pad)) {
            lane.rejected_tf = std::min(lane.rejected_tf, tf);
        }
        return;
    }
    if (occlusion)
        return;
    h->object = g.object;
    h->primitive = prim;
    if (lane.collect) {
        lane.collect->push_back(*h);
        args->valid[i] = 0;
        return;
    }
    if (!keep_if_closer(lane, *h, tf, tfar))
        args->valid[i] = 0;  // Embree then restores tfar to the best's
}

/// A packet's candidates on one triangle, up to four lanes at a time (intersect_triangle_lanes,
/// or decide_triangle_lanes for `occlusion`: the same answers bit for bit; the lanes it leaves
/// undecided by intersect_triangle or decide_triangle). Embree's packet kernels report a triangle
/// with every lane of the packet that hit it: about four on the bench's camera rays (workload A),
/// where Woop's test and the plane crossing one lane at a time had been over half of a refined
/// batch (callgrind).
void decide_packet(const RTCFilterFunctionNArguments* args, RayContext& c, const GeomData& g,
                   const TriangleMesh& mesh, bool occlusion) {
    unsigned lane_of[4];      // the filter's lane i
    RayContext* contexts[4];  // its ray's context (by the ray's id: Embree may hand a packet of
                              // 16 over in halves of 8, whose lane i is ray 8 + i)
    const Ray* rays[4];
    unsigned count = 0, prim = 0;
    bool want_normal = false;
    auto flush = [&] {
        if (count == 0)
            return;
        const Triangle tri = mesh.triangle(prim);
        std::optional<Hit> hits[4];
        LineCrossing outside[4];
        // A lane alone is decided one at a time (decide's comment).
        const unsigned undecided =
            count == 1  ? 1u
            : occlusion ? decide_triangle_lanes(tri, rays, count, hits, outside)
                        : intersect_triangle_lanes(tri, rays, count, want_normal, hits, outside);
        for (unsigned k = 0; k < count; ++k) {
            if (undecided & (1u << k)) {
                hits[k] = occlusion ? decide_triangle(tri, *rays[k], &outside[k])
                                    : intersect_triangle(tri, *rays[k], want_normal, &outside[k]);
            }
            settle(args, lane_of[k], *contexts[k], g, prim, tri, hits[k], outside[k], occlusion);
        }
        count = 0;
    };
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1)
            continue;
        const unsigned p = RTCHitN_primID(args->hit, args->N, i);
        RayContext& lane = c.lanes[RTCRayN_id(args->ray, args->N, i)];
        // Not seen reached with a lane pending: on Embree 3.13.5 no packet flagged incoherent of
        // the tests (nor 400 packets of fifteen rays bundled and a stray one, tried) handed a
        // pending lane to a call of several lanes. It keeps the order decide() needs if one did.
        if (c.defer && !occlusion && !ready_to_decide(lane))
            continue;
        // One triangle and one want_normal a call of the kernel (Embree reports one triangle a
        // call; nothing here relies on it).
        if (count == 4 || (count > 0 && (p != prim || lane.want_normal != want_normal)))
            flush();
        prim = p;
        want_normal = lane.want_normal;
        lane_of[count] = i;
        contexts[count] = &lane;
        rays[count] = lane.ray;
        ++count;
    }
    flush();
}

/// Decides each float candidate Embree reports on a fat triangle by the double watertight test
/// on the real triangle (intersect_triangle, which also enforces [tmin, tmax]): a double miss is
/// rejected (the traversal goes on) and noted in the ray's context (rejected_tf); a double hit is
/// recorded and rejected (`all`), ends the traversal (`any`), or (closest) competes with the
/// context's `best` by the API's order (`closer`: double t, then the lower object, then the
/// lower primitive) and is accepted only if it comes first (keep_if_closer).
/// Embree offers candidates in no particular order and, on an accepted hit, sets tfar to its
/// float t, then offers later candidates with t <= tfar: taking every accepted hit (as until
/// 2026-12-05) gave an exact tie in double t to whichever triangle came last, the higher index
/// on duplicated meshes and on shared edges (API.md says the lower).
void decide(const RTCFilterFunctionNArguments* args, bool occlusion) {
    RayContext& c = ctx_of(args->context);
    const auto* g = static_cast<const GeomData*>(args->geometryUserPtr);
    const TriangleMesh& mesh = *g->accel->scene->objects[g->object].mesh;
    // A lane alone (most calls on random rays) costs less one at a time: the kernel's per-call
    // set-up and its four lanes had added 164 instructions a ray on A's random rays (callgrind,
    // 1,374 -> 1,539 M for 1M rays), and the grouping another 51 where it went by one lane.
    if (c.lanes && triangle_lanes_available()) {
        unsigned valid = 0;
        for (unsigned i = 0; i < args->N; ++i)
            valid += args->valid[i] == -1 ? 1u : 0u;
        if (valid > 1) {
            decide_packet(args, c, *g, mesh, occlusion);
            return;
        }
    }
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1)
            continue;
        // A packet's context carries its lanes; the ray id is the lane (fill_lanes).
        RayContext& lane = c.lanes ? c.lanes[RTCRayN_id(args->ray, args->N, i)] : c;
        const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
        if (c.defer && !occlusion) {
            const auto well_inside = [&] {  // GeomData::defer_band2
                const float bu = RTCHitN_u(args->hit, args->N, i);
                const float bv = RTCHitN_v(args->hit, args->N, i);
                const float inside = std::min({bu, bv, 1.0f - bu - bv});
                const float nx = RTCHitN_Ng_x(args->hit, args->N, i);
                const float ny = RTCHitN_Ng_y(args->hit, args->N, i);
                const float nz = RTCHitN_Ng_z(args->hit, args->N, i);
                return inside > 0.0f &&
                       inside * inside * (nx * nx + ny * ny + nz * nz) > g->defer_band2;
            };
            if (!lane.best && !lane.pending_geom && !lane.retrace && !lane.collect &&
                well_inside()) {
                // Accepted undecided: Embree keeps tfar at its float t (settle_pending_lanes).
                lane.pending_geom = g;
                lane.pending_prim = prim;
                lane.pending_tf = RTCRayN_tfar(args->ray, args->N, i);
                ++t_deferral_counts.deferred;
                __builtin_prefetch(&mesh.triangles[prim]);
                continue;
            }
            if (!ready_to_decide(lane))
                continue;
        }
        const Triangle tri = mesh.triangle(prim);
        // An occlusion query needs only the decision (decide_triangle: the plane crossing only
        // where Woop's t does not settle the range).
        LineCrossing outside;
        auto h = occlusion ? decide_triangle(tri, *lane.ray, &outside)
                           : intersect_triangle(tri, *lane.ray, lane.want_normal, &outside);
        settle(args, i, lane, *g, prim, tri, h, outside, occlusion);
    }
}

void intersect_filter(const RTCFilterFunctionNArguments* args) {
    decide(args, /*occlusion=*/false);
}

void occluded_filter(const RTCFilterFunctionNArguments* args) {
    decide(args, /*occlusion=*/true);
}

}  // namespace

void settle_pending_lanes(RayContext* lanes, std::size_t m) {
    // The index rows were prefetched when the candidates were deferred; the corners of every
    // lane are asked for before any is read, so that their misses overlap.
    for (std::size_t k = 0; k < m; ++k) {
        const RayContext& lane = lanes[k];
        if (!lane.pending_geom)
            continue;
        const TriangleMesh& mesh = pending_mesh(lane);
        for (const std::uint32_t v : mesh.triangles[lane.pending_prim]) {
            const char* p = reinterpret_cast<const char*>(&mesh.positions[v]);
            __builtin_prefetch(p);
            __builtin_prefetch(p + sizeof(Vec3d) - 1);  // a corner may straddle two lines
        }
    }
    for (std::size_t k = 0; k < m; ++k) {
        if (lanes[k].pending_geom && !settle_pending(lanes[k])) {
            lanes[k].retrace = true;
            ++t_deferral_counts.retraced;
        }
    }
}

DeferralCounts& deferral_counts() {
    return t_deferral_counts;
}

bool crossed_well_inside(const Triangle& tri, double u, double v, const Vec3d& d, double delta) {
    const Vec3d n = cross(tri.b - tri.a, tri.c - tri.a);
    const double nn = length(n);
    const double sin_beta = std::abs(dot(n, d)) / (nn * length(d));
    if (!(sin_beta >= 1.0 / 16.0))
        return false;
    // A barycentric weight times the altitude |n|/|e| over the opposite edge e is the distance
    // from that edge; the double kernel's u, v are exact to far below Δ (16·u_f of the scene).
    const double inset = 2.0 * delta / sin_beta + 2.0 * delta;
    return (1.0 - u - v) * nn >= inset * length(tri.c - tri.b) &&
           u * nn >= inset * length(tri.a - tri.c) && v * nn >= inset * length(tri.b - tri.a);
}

bool outside_range_well_inside(const Triangle& tri, const LineCrossing& outside, const Ray& ray,
                               double delta) {
    return outside.crossed && crossed_well_inside(tri, outside.u, outside.v, ray.direction, delta);
}

/// The three corners of `tri` (relative to the scene centre) with its edges moved out by w in
/// its plane. Corner i lies on two edges with outward in-plane unit normals m₁, m₂; the moved
/// edges meet at corner + x with x·m₁ = x·m₂ = w, i.e. x = w·(m₁ + m₂)/(1 + m₁·m₂), of length
/// w/sin(α/2) (α the corner's angle; 1 + m₁·m₂ = 2 sin²(α/2) never cancels at an obtuse corner,
/// unlike the bisector form −w(e₁ + e₂)/sin α). Corners sharper than kMinCornerSine are capped.
void widen_triangle(const Triangle& tri, double w, Vec3d out[3], bool& capped) {
    const Vec3d p[3] = {tri.a, tri.b, tri.c};
    const Vec3d n = cross(p[1] - p[0], p[2] - p[0]);
    Vec3d m[3];  // m[i]: outward normal of the edge p[i] → p[i+1], in the plane
    for (int i = 0; i < 3; ++i) {
        const Vec3d e = p[(i + 1) % 3] - p[i];
        Vec3d o = normalize(cross(e, n));
        if (dot(o, p[(i + 2) % 3] - p[i]) > 0.0)
            o = -o;
        m[i] = o;
    }
    const double max_len = w / kMinCornerSine;
    for (int i = 0; i < 3; ++i) {
        const Vec3d& m1 = m[(i + 2) % 3];  // the edge arriving at corner i
        const Vec3d& m2 = m[i];            // the edge leaving it
        Vec3d x = (m1 + m2) * (w / (1.0 + dot(m1, m2)));
        const double len = length(x);
        if (!(len <= max_len)) {  // also a 0/0 at a corner of angle ~0
            capped = true;
            const double l = length(m1 + m2);
            x = l > 0.0 ? (m1 + m2) * (max_len / l) : Vec3d{};
        }
        out[i] = p[i] + x;
    }
}

GeometryHandle make_fat_triangle_geometry(RTCDevice device, const TriangleMesh& mesh, const Impl& a,
                                          double widen_by, GeomData* data, bool& capped,
                                          BuildBuffer& buffer) {
    const std::size_t n = mesh.size();
    // In memory of ours, which EmbreeAccel::build releases once the BVH is built (build_buffer.h).
    GeometryHandle g(rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE));
    float* v;
    unsigned* idx;
    if (!share_triangle_buffers(g.get(), buffer, 3 * n, n, v, idx))
        return nullptr;  // no memory (the caller says so)
    // The longest widened edge, squared (GeomData::defer_band2).
    double longest2 = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const Triangle t = mesh.triangle(i);
        // Widened in Embree's frame (Impl::frame, an exact scaling): its cross products are of
        // unit-sized edges. In scene units they underflowed for meshes below ~1e-105 across (no
        // widening, so refined missed hits near edges while certifying its misses) and
        // overflowed above ~5e102 (every corner capped: nothing certified). A helper's review.
        const Triangle rel{a.frame(t.a), a.frame(t.b), a.frame(t.c)};
        Vec3d out[3] = {rel.a, rel.b, rel.c};
        if (!is_degenerate(t))  // a degenerate triangle is never hit in double: left as it is
            widen_triangle(rel, widen_by * a.unit, out, capped);
        for (std::size_t k = 0; k < 3; ++k) {
            const Vec3d e = out[(k + 1) % 3] - out[k];
            longest2 = std::max(longest2, dot(e, e));
            // to_float: see make_triangle_geometry.
            const Vec3d& q = out[k];
            v[9 * i + 3 * k + 0] = to_float(q.x);
            v[9 * i + 3 * k + 1] = to_float(q.y);
            v[9 * i + 3 * k + 2] = to_float(q.z);
            idx[3 * i + k] = static_cast<unsigned>(3 * i + k);
        }
    }
    const double band = 2.0 * widen_by * a.unit * std::sqrt(longest2);
    data->defer_band2 = static_cast<float>(std::min(band * band, 1e30));
    rtcSetGeometryUserData(g.get(), data);
    rtcSetGeometryIntersectFilterFunction(g.get(), intersect_filter);
    rtcSetGeometryOccludedFilterFunction(g.get(), occluded_filter);
    return g;
}

}  // namespace raycastd::engine::embree
