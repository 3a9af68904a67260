#pragma once
// The float ray Embree traces for a double ray, and Embree's float hit read back.
//
// Two set-ups (both in Embree's frame, Impl::frame: relative to the scene centre and scaled to
// unit size):
//   prepare_ray       the ray's segment clipped to the padded scene bounds (Kay & Kajiya slabs,
//                     in double), starting where it enters them, with a unit direction: a far
//                     origin or an extreme direction length then costs no float precision. The
//                     start point is formed in double-double when plain double would round it
//                     beyond the exact BVH's box padding.
//   prepare_ray_fast  the ray as it is (no clipping, no renormalisation; float t is the
//                     client's t times Impl::unit), for fast, where that loses nothing the float
//                     kernel had anyway.
// Either way the 12 fields of Embree's ray are written by one helper, fill_lane, for a single
// RTCRay or for lane k of an RTCRay16; intersect1 and occluded1 trace a single one.

#include <algorithm>
#include <cmath>
#include <cstddef>

#include <embree3/rtcore.h>

#include "engine/accel/embree/impl.h"
#include "engine/accel/far_ray.h"
#include "engine/math/double_double.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine::embree {

/// A float ray's geometry as Embree takes it: origin in Embree's frame (Impl::frame), direction,
/// and the range [tnear, tfar] (RayContext::len maps it to the double ray's t).
struct FloatRay {
    float org_x = 0.0f, org_y = 0.0f, org_z = 0.0f;
    float dir_x = 0.0f, dir_y = 0.0f, dir_z = 0.0f;
    float tnear = 0.0f, tfar = 0.0f;
};

/// A single ray's field itself, or lane k of a packet's field: fill_lane and native_hit read and
/// write an RTCRay(Hit) and lane k of an RTCRay(Hit)16 with the same code.
template <class T>
inline T& lane(T& field, std::size_t) {
    return field;
}
template <class T, std::size_t N>
inline T& lane(T (&field)[N], std::size_t k) {
    return field[k];
}

/// Writes the 12 fields of an Embree ray (org, dir, tnear, tfar, time, mask, id, flags): `r` is
/// an RTCRay (k is ignored) or an RTCRay16 (lane k).
template <class EmbreeRay>
inline void fill_lane(EmbreeRay& r, std::size_t k, const FloatRay& f, unsigned id) {
    lane(r.org_x, k) = f.org_x;
    lane(r.org_y, k) = f.org_y;
    lane(r.org_z, k) = f.org_z;
    lane(r.dir_x, k) = f.dir_x;
    lane(r.dir_y, k) = f.dir_y;
    lane(r.dir_z, k) = f.dir_z;
    lane(r.tnear, k) = f.tnear;
    lane(r.tfar, k) = f.tfar;
    lane(r.time, k) = 0.0f;
    lane(r.mask, k) = 0xFFFFFFFFu;  // Debian's Embree is built with ray masks: 0 would hit nothing
    lane(r.id, k) = id;
    lane(r.flags, k) = 0;
}

/// The float ray fill_lane wrote into `r` (k ignored) or lane k of an RTCRay16.
template <class EmbreeRay>
inline FloatRay float_ray_of(const EmbreeRay& r, std::size_t k) {
    FloatRay f;
    f.org_x = lane(r.org_x, k);
    f.org_y = lane(r.org_y, k);
    f.org_z = lane(r.org_z, k);
    f.dir_x = lane(r.dir_x, k);
    f.dir_y = lane(r.dir_y, k);
    f.dir_z = lane(r.dir_z, k);
    f.tnear = lane(r.tnear, k);
    f.tfar = lane(r.tfar, k);
    return f;
}

/// What Embree reported for an RTCRayHit (k ignored) or lane k of an RTCRayHit16.
template <class EmbreeRayHit>
inline NativeHit native_hit(const EmbreeRayHit& rh, std::size_t k) {
    return NativeHit{lane(rh.hit.geomID, k),
                     lane(rh.hit.primID, k),
                     lane(rh.ray.tfar, k),
                     lane(rh.hit.u, k),
                     lane(rh.hit.v, k),
                     Vec3d{lane(rh.hit.Ng_x, k), lane(rh.hit.Ng_y, k), lane(rh.hit.Ng_z, k)}};
}

/// The part [t0, t1] of the ray's segment [tmin, tmax] inside the padded scene bounds; false
/// when there is none (nothing can be hit).
bool clip_to_bounds(const Impl& a, const Ray& ray, double& t0, double& t1);
/// The same against `bounds`.
bool clip_to_bounds(const Bounds3& bounds, const Ray& ray, double& t0, double& t1);

/// Whether the ray's segment meets the padded scene bounds.
inline bool enters_bounds(const Impl& a, const Ray& ray) {
    double t0, t1;
    return clip_to_bounds(a, ray, t0, t1);
}

/// The slack prepare_ray leaves above a segment's float end (RayContext::margin): the exact
/// BVH's 4 pads, in Embree's frame (Impl::unit). One expression, so that the set-up four lanes
/// at a time (embree/packets.cpp) forms the same bits.
inline double float_margin(const Impl& a) {
    return 4.0 * a.pad * a.unit;
}

/// tfar for a candidate at double t: never below it, whatever the float rounding.
inline float tfar_for(const RayContext& c, double t) {
    return float_up((t - c.shift) * c.len + c.margin);
}

/// Whether keep_if_closer leaves tfar a margin above the hit `h`: within 1e-6 of its triangle's
/// edges in barycentrics, far above the double kernel's rounding (a sphere's u = v = 0 counts).
inline bool near_edge(const Hit& h) {
    constexpr double kEdge = 1e-6;
    return h.u <= kEdge || h.v <= kEdge || 1.0 - h.u - h.v <= kEdge;
}

/// refined's closest on the native BVH (the fat triangles' hit filter and the spheres'
/// callback): keeps the double hit `h`, whose float t is `tf`, as c.best if it comes first by
/// the API's order (`closer`: double t, then the lower object, then the lower primitive) and
/// returns true; false leaves c.best as it is, and the caller rejects `h`.
/// On keeping, sets `tfar` (the float ray's) a margin above h, as the exact BVH's callback does:
/// Embree offers a later candidate only where its float t <= tfar, and a triangle whose double t
/// ties h's at a shared edge or vertex (a widened float triangle of its own) may round to a
/// float t above h's; it is then still offered, and `closer` decides whatever the traversal's
/// order. (A candidate so offered that misses in double is not a rejection: see the filter.)
/// fast's lanes keep tfar at tf: fast reads its t from Embree's tfar. So does a hit away from
/// its triangle's edges: a triangle tying its double t there lies in the same plane over the
/// point, a duplicate (whose widened copy has the same float t, offered as t <= tfar) or another
/// object's overlapping coplanar face, whose widened float triangle may round its t a few ulps
/// higher and then not be offered: between such faces refined's choice stays a float decision
/// (docs/numerics.md; exact applies the tie rule). Raising tfar for them costs every hit:
/// measured with bench_intersect A, paired runs, intersect_blocks on camera rays went from
/// 0.95–1.04x of rtcIntersect1 to 0.74–0.94x with 4 ulps, 0.79–0.82x with 16 ulps and
/// 0.82–0.90x with the exact margin. Spheres (u = v = 0) count as on an edge.
inline bool keep_if_closer(RayContext& c, const Hit& h, float tf, float& tfar) {
    if (c.best && !closer(h, *c.best))
        return false;
    c.best = h;
    c.best_tf = tf;
    tfar = c.fast || !near_edge(h) ? tf : std::max(tf, tfar_for(c, h.t));
    return true;
}

/// Where prepare_ray starts the float ray.
enum class RayStart {
    at_entry,    ///< where the segment enters the padded bounds (the native BVHs)
    backed_off,  ///< the padding before it, so that a hit at exactly tmin lies strictly inside
                 ///< the float segment (the exact BVH; its double test still enforces tmin)
};

/// What a ray's coordinates are relative to.
enum class RayFrame {
    world,   ///< the client's coordinates
    centre,  ///< relative to the scene centre (Impl::center): a far ray moved to the scene
};

/// Sets up the clipped float ray for `ray` in `f` and its mapping back to the double ray in `c`
/// (shift, len, margin, origin_err, far, frame); false, with `f` untouched, when the ray's
/// segment misses the padded bounds altogether.
bool prepare_ray(const Impl& a, const Ray& ray, RayStart start, RayContext& c, FloatRay& f,
                 RayFrame frame = RayFrame::world);

/// Whether prepare_ray_fast applies to `ray`, whose origin relative to the scene centre is org:
/// tmin ≥ 0, an origin within 4 scene sizes of the centre on every axis (at most 8 in Embree's
/// frame), and |d|² in [1e-12, 1e12].
inline bool fast_ray_applies(const Impl& a, const Ray& ray, const Vec3d& org) {
    const double d2 = dot(ray.direction, ray.direction);
    // Each coordinate, not |org|² against 16·scale²: that overflowed for scenes past ~1.7e153
    // across, and any origin passed (a helper's review). Not max_abs either: its std::max drops
    // a NaN in some positions, and such an origin would pass.
    return ray.tmin >= 0.0 && within_reach(org, 4.0 * a.float_scale) && d2 >= 1e-12 && d2 <= 1e12;
}

/// The unclipped float ray of `ray` (origin in Embree's frame, direction as given, range times
/// Impl::unit) in `f`; false, with `f` untouched, where fast_ray_applies does not hold.
inline bool unclipped_float_ray(const Impl& a, const Ray& ray, FloatRay& f) {
    const Vec3d org = ray.origin - a.center;
    if (!fast_ray_applies(a, ray, org))
        return false;
    // In float's range: within 4 scene sizes of the centre, which Impl::unit brings to 8 at
    // most (see fast_ray_applies); the direction as it is, so float t is t·unit.
    const Vec3d q = org * a.unit;
    f.org_x = static_cast<float>(q.x);
    f.org_y = static_cast<float>(q.y);
    f.org_z = static_cast<float>(q.z);
    f.dir_x = static_cast<float>(ray.direction.x);
    f.dir_y = static_cast<float>(ray.direction.y);
    f.dir_z = static_cast<float>(ray.direction.z);
    f.tnear = to_float(ray.tmin * a.unit);
    f.tfar = to_float(ray.tmax * a.unit);  // +inf stays +inf
    return true;
}

/// The fast path's float ray: the double ray as it is (unclipped_float_ray), with shift 0 and
/// len Impl::unit in `c`, used when that loses nothing the float kernel had anyway; false where
/// it does not apply (then prepare_ray).
inline bool prepare_ray_fast(const Impl& a, const Ray& ray, RayContext& c, FloatRay& f) {
    if (!unclipped_float_ray(a, ray, f))
        return false;
    c.ray = &ray;
    c.shift = 0.0;
    c.len = a.unit;  // float t = t·unit (unclipped_float_ray)
    c.margin = 0.0;
    return true;
}

/// fast's float ray on its BVH: prepare_ray_fast where it applies, else prepare_ray; spheres
/// are then decided by the plain-double kernel (c.fast). Spheres take the unclipped ray too:
/// their callback works in the client's t units with shift 0 and len Impl::unit, and a sphere
/// culled by its box within the float rounding of the unclipped ray is within what fast promises.
/// Measured: clipping and normalising cost 17% of a fast render of spheres.
inline bool prepare_fast_native_ray(const Impl& a, const Ray& ray, RayContext& c, FloatRay& f) {
    c.fast = true;
    return prepare_ray_fast(a, ray, c, f) || prepare_ray(a, ray, RayStart::at_entry, c, f);
}

/// Whether the float ray prepare_ray set up is within the exact BVH's box padding of the double
/// ray: its start point's double rounding (c.origin_err, plain or double-double) must stay
/// well inside the padding. Rays where it does not take the linear scan.
inline bool exact_ray_within_padding(const Impl& a, const RayContext& c) {
    return c.origin_err <= 0.25 * a.pad;
}

/// For a ray prepare_ray marked far (RayContext::far: an origin ~1e8 scene sizes away and
/// beyond, where the double kernels deciding on the ray itself err by ~u·distance, and from
/// ~1e16 on the float ray cannot even be placed): the same line, relative to the scene centre,
/// with its origin moved along it to just before the padded bounds, formed in double-double.
/// `misses` where the line passes outside the bounds; `not_possible` for a direction whose |d|²
/// leaves double's normal range, or an origin past ~1e30 scene sizes, where double-double
/// cannot hold the shift finely enough.
MoveResult move_near_scene(const Impl& a, const Ray& ray, MovedRay& out);

/// Whether prepare_ray may mark `ray` far: false guarantees it will not (an origin within 2^24
/// float scales of the centre on every axis; the double-double start point needs ~2^25). The
/// packets of refined's `any` send a group with a far ray through the single-ray path.
inline bool maybe_far(const Impl& a, const Ray& ray) {
    return !within_reach(ray.origin - a.center, 0x1p24 * a.float_scale);
}

/// Whether prepare_ray could not place the float ray near the scene (an origin so far that the
/// slab test's rounding puts the start point outside the bounds): its float segment is empty,
/// and the exact path answers it moved to the scene (move_near_scene), or where that is not
/// possible by the linear scan (exact_ray_within_padding is false too).
inline bool unplaced(const RayContext& c) {
    return c.origin_err == std::numeric_limits<double>::infinity();
}

/// One float ray traced on `scene` for its closest hit; the callbacks see `c`.
inline RTCRayHit intersect1(RTCScene scene, RayContext& c, const FloatRay& f) {
    RTCRayHit rh;
    fill_lane(rh.ray, 0, f, 0);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &c.rtc, &rh);
    return rh;
}

/// Whether one float ray finds anything on `scene`; the callbacks see `c`.
inline bool occluded1(RTCScene scene, RayContext& c, const FloatRay& f) {
    RTCRay r;
    fill_lane(r, 0, f, 0);
    rtcOccluded1(scene, &c.rtc, &r);
    return occluded_tfar(r.tfar);
}

/// fast's answer from Embree's float hit `nh` on a triangle of the ray whose float set-up had
/// `shift` and `len`: t in the client's units (clamped to the range asked for), a float-sized
/// t_err, and Embree's float normal. Nothing of the double triangle is read: that would cost a
/// cache miss per ray (~15% of an incoherent batch) for digits fast does not promise.
inline void fast_hit(const Impl& a, const Ray& ray, double shift, double len, const NativeHit& nh,
                     bool want_normal, Hit& h) {
    h.t = std::min(std::max(shift + static_cast<double>(nh.tfar) / len, ray.tmin), ray.tmax);
    // A float kernel: relative error of a few float ulps of the scene's coordinates.
    h.t_err =
        gamma_float(12) *
        ((a.float_scale + length(ray.origin - a.center)) / length(ray.direction) + std::abs(h.t));
    h.object = nh.geom;
    h.primitive = nh.prim;
    h.u = nh.u;
    h.v = nh.v;
    // Embree's Ng = (v2−v0)×(v0−v1) = (b−a)×(c−a) up to rounding: its sign gives the side.
    h.front_face = dot(ray.direction, nh.ng) < 0.0;
    h.on_edge = false;
    if (want_normal) {
        const double l = length(nh.ng);
        h.normal = l > 0.0 ? nh.ng / l : Vec3d{};
    } else {
        h.normal = Vec3d{};
    }
}

}  // namespace raycastd::engine::embree
