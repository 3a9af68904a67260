#pragma once
// refined's float triangles: each mesh triangle widened in its own plane, traced by Embree's
// watertight float kernel, every float candidate decided by the double watertight test in a hit
// filter, so that one traversal both picks and decides (issue 17).
//
// Why widen. refined used to confirm every float miss on the exact BVH (a second traversal),
// because a float miss can be wrong: the float ray and the float vertices are the double ones
// rounded, and Embree's float test rounds again. All of that moves the float line, relative to
// the float triangle, by less than Δ ≈ 16·u_f·S (S = Impl::float_scale: vertex and ray-origin
// rounding u_f·S each, the unit direction's u_f over a segment of at most S, Embree's Plücker
// edge functions a few u_f of the coordinates relative to the origin; Higham 2002, Lemma 3.1).
// A triangle widened by w = kWidenPads·pad = 16Δ in its plane (its edges moved out by w, the
// vertices to where the moved edges meet: w/sin(α/2) along the bisector of the angle α) then
// contains the float line's crossing of the plane whenever the double line crosses the triangle
// at an angle β to the plane with sin β ≥ Δ/w, i.e. β ≥ 3.6°. So the float traversal reports
// every triangle the double ray hits, except where the ray grazes a triangle within ~Δ of one of
// its edges, which the float near-tie bands of docs/accuracy.md already leave undecided; the
// hit filter decides each reported candidate in double and rejects what the double test misses.
// A float miss is then a miss, and needs no second traversal, unless the filter rejected a
// candidate on the way (the ray passed within w of an edge: it goes to the exact path), or the
// scene is not certified (below).
//
// A sliver's bisector offset w/sin(α/2) grows without bound. A corner sharper than 3.6°
// (sin(α/2) < kMinCornerSine) is moved by at most w/kMinCornerSine, which no longer covers the
// whole w-neighbourhood of the corner; a scene with any such triangle is not certified
// (Impl::certified_misses = false) and refined confirms its float misses on the exact BVH as
// before. Degenerate triangles (never hit in double) are left as they are.

#include <vector>

#include <embree3/rtcore.h>

#include "engine/accel/embree/build_buffer.h"
#include "engine/accel/embree/device.h"
#include "engine/scene/scene.h"

namespace raycastd::engine::embree {

struct GeomData;
struct Impl;
struct RayContext;

/// The in-plane widening of refined's triangles, in units of Impl::pad (8·u_f·S): 32 pads, 256
/// u_f·S, 16× the float displacement Δ above (sin β ≥ 1/16: β ≥ 3.6°).
constexpr double kWidenPads = 32.0;

/// A corner sharper than this sine of half its angle is capped (the scene is not certified).
constexpr double kMinCornerSine = 1.0 / 32.0;

/// The corners of `tri` with its edges moved out by `w` in its plane (out[0..3) for a, b, c): each
/// corner moves w/sin(α/2) along its bisector, at most w/kMinCornerSine (then `capped` is set).
/// `tri` must not be degenerate.
void widen_triangle(const Triangle& tri, double w, Vec3d out[3], bool& capped);

/// refined's deferred decisions (RayContext::defer), after the packet's traversal: decides each
/// of lanes[0..m)'s pending candidate as the hit filter would have when Embree offered it, the
/// lanes' corners prefetched together first. A lane whose decision would have changed the
/// traversal (a double miss, a hit near an edge) is marked RayContext::retrace, and its answer
/// must be traced again without deferral.
void settle_pending_lanes(RayContext* lanes, std::size_t m);

/// What refined's deferred decisions did on this thread: candidates accepted undecided, and
/// lanes marked to be traced again. The answers are the same with or without the deferral, so
/// nothing but these counts tells that it is taken at all: tests read them
/// (EmbreeAccel.RefinedRandomPacketsAnswerAsSingleRays). Each thread counts on its own counters,
/// one increment a deferral. The counts depend on the processor: decide_packet, which decides
/// several lanes at once where the processor has AVX2 and FMA, never defers.
struct DeferralCounts {
    std::uint64_t deferred = 0;
    std::uint64_t retraced = 0;
};
DeferralCounts& deferral_counts();

/// Whether a double hit at barycentrics (u, v) of `tri` (u the weight of b, v of c), on a line
/// along `d`, crosses at sin β ≥ 1/16 and at least 2Δ/sin β + 2Δ from every edge. The float
/// line, within Δ of the double one relative to the float triangle, then crosses its plane at
/// most Δ/sin β from the double crossing: more than Δ inside the unwidened float triangle
/// (refined's back faces, embree_accel.cpp exits_well_inside). False for a degenerate triangle
/// or a NaN anywhere.
bool crossed_well_inside(const Triangle& tri, double u, double v, const Vec3d& d, double delta);

/// Whether `outside`, where intersect_triangle found the line of `ray` crossing `tri` outside
/// [tmin, tmax], is crossed as crossed_well_inside asks (ray.direction, `delta`): a candidate the
/// double test rejected for its t alone, far from the triangle's edges. The hit filter does not
/// count such a rejection (RayContext::rejected_tf); what it spares is a spawned ray's own
/// triangle, which the float ray, started a margin before tmin, crosses just behind the origin
/// (in a refined render of the Duck 8.1 of 10.5 million unblocked shadow rays went to the exact
/// path for it: docs/numerics.md).
/// Why that is safe. A rejection stands for a ray that passed within the widening of an edge of
/// a triangle it does not hit, where it may have slipped through the float surface. Here the
/// float line crosses the unwidened float triangle more than Δ inside it (Δ/sin β + 2Δ less
/// the vertices' rounding), at sin β ≥ 1/16, on the side the double line crosses the real one:
/// a crossing the float and the double line both make, near none of the triangle's edges,
/// after which both are on the same side of the surface. Not counting it leaves a spawned ray where
/// any other ray is: float and double disagree unseen only where the double line makes a crossing
/// the float line does not, at sin β < 1/16 within ~Δ/sin β of an edge (a ridge clipped less deeply
/// than Δ, a part thinner than ~2Δ between the float start and tmin), inside the float bands of
/// docs/accuracy.md. What the old rule bought there was that every spawned ray took the exact
/// path. The fuzzer spawns such rays, outward and inward, since 2026-12-06
/// (tests/stress/fuzz_test.cpp, spawned_case); a helper's review found no case outside the bands.
bool outside_range_well_inside(const Triangle& tri, const LineCrossing& outside, const Ray& ray,
                               double delta);

/// The float triangle geometry of `mesh` (in a's frame: Impl::frame) with each triangle
/// widened by `widen` in its plane (three vertices of its own, so neighbours may overlap), the
/// hit filters below attached, user data `data`. `capped` is set when a sliver could not be
/// widened fully (see above). Its vertices and indices are carved from `buffer`, which must
/// outlive the geometry (build_buffer.h: fat_triangle_bytes of it); null where it has no room.
/// Not yet committed.
GeometryHandle make_fat_triangle_geometry(RTCDevice device, const TriangleMesh& mesh, const Impl& a,
                                          double widen, GeomData* data, bool& capped,
                                          BuildBuffer& buffer);
/// Bytes of a BuildBuffer make_fat_triangle_geometry carves for `mesh`: three vertices of its
/// own a triangle.
inline std::size_t fat_triangle_bytes(const TriangleMesh& mesh) {
    return triangle_buffer_bytes(3 * mesh.size(), mesh.size());
}

}  // namespace raycastd::engine::embree
