// EmbreeAccel::closest_point: Embree's point query (rtcPointQuery) culls, our double kernels
// decide (engine/accel/point_query.h).
//
// Embree traverses its float BVH with a query sphere and calls back for every primitive whose box
// meets it; the callback computes the primitive's exact closest point in double and shrinks the
// sphere to what can still win. Float only culls, so the sphere is widened by everything float
// can have moved: the query point's rounding relative to the scene centre, the boxes' (float
// vertices, and Impl::pad on user geometry), and the rounding of Embree's own box distance
// (a few u_f of the point's distance from the centre plus the radius; 8 u_f is used).

#include "engine/accel/point_query.h"

#include <cmath>

#include <embree3/rtcore.h>

#include "engine/accel/embree/impl.h"
#include "engine/accel/embree_accel.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine {

namespace {

/// Query points farther than this from the scene centre are answered by brute force: float
/// could not hold them (and from so far away every primitive is a candidate anyway).
constexpr double kMaxFloatQueryDistance = 1e30;

/// What travels through rtcPointQuery to the callback (its userPtr).
struct PointContext {
    const embree::Impl* accel;
    Vec3d p;
    double max_distance;
    double from_centre;  ///< |p − centre|
    PointCandidates candidates;

    /// The float query radius that covers every primitive within `d` of p in double.
    float radius_for(double d) const {
        if (!(d < kInfinity))
            return std::numeric_limits<float>::infinity();
        const double slack =
            accel->pad + 8.0 * kFloatUnitRoundoff * (from_centre + d + accel->float_scale);
        return float_up((d + slack) * accel->unit);  // in Embree's frame (Impl::unit)
    }
};

bool point_callback(RTCPointQueryFunctionArguments* args) {
    auto& c = *static_cast<PointContext*>(args->userPtr);
    offer_primitive(*c.accel->scene, args->geomID, args->primID, c.p, c.max_distance, c.candidates);
    const float r = c.radius_for(std::fmin(c.max_distance, c.candidates.cull_distance()));
    if (r < args->query->radius) {
        args->query->radius = r;
        return true;  // Embree's signal that the query sphere shrank
    }
    return false;
}

}  // namespace

std::optional<PointHit> EmbreeAccel::closest_point(const Vec3d& p, double max_distance) const {
    const embree::Impl& a = *impl_;
    const Vec3d q = a.frame(p);
    // The padded bounds contain the scene's: a bound on every candidate's err all the same.
    PointContext c{&a, p, max_distance, length(p - a.center),
                   PointCandidates(candidate_err_bound(p, a.padded_bounds))};
    if (!(c.from_centre * a.unit <= kMaxFloatQueryDistance))
        return linear_closest_point(*a.scene, p, max_distance);
    RTCPointQuery query;
    query.x = static_cast<float>(q.x);
    query.y = static_cast<float>(q.y);
    query.z = static_cast<float>(q.z);
    query.time = 0.0f;
    query.radius = c.radius_for(max_distance);
    RTCPointQueryContext context;
    rtcInitPointQueryContext(&context);
    rtcPointQuery(a.native.get(), &query, &context, point_callback, &c);
    return finish_closest_point(*a.scene, c.candidates);
}

}  // namespace raycastd::engine
