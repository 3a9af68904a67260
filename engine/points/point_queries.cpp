#include "engine/points/point_queries.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "engine/huge_pages.h"
#include "engine/points/batch.h"
#include "engine/points/inside.h"

namespace raycastd::engine {

namespace {

/// The nearest surface point as the API reports it: on a surface, the point itself at distance 0.
PointHit as_reported(PointHit h, const Vec3d& p) {
    if (on_surface(h)) {
        h.point = p;
        h.distance = 0.0;
    }
    return h;
}

}  // namespace

const char* to_string(PointQuery q) {
    switch (q) {
        case PointQuery::closest:
            return "closest";
        case PointQuery::distance:
            return "distance";
        case PointQuery::signed_distance:
            return "signed_distance";
        case PointQuery::occupancy:
            return "occupancy";
    }
    return "closest";
}

std::optional<PointQuery> point_query_from_string(std::string_view name) {
    for (PointQuery q : {PointQuery::closest, PointQuery::distance, PointQuery::signed_distance,
                         PointQuery::occupancy}) {
        if (name == to_string(q))
            return q;
    }
    return std::nullopt;
}

Status query_points(const QueryEngine& engine, const std::vector<Vec3d>& points,
                    const PointOptions& options, std::vector<PointAnswer>& out) {
    const std::size_t n = points.size();
    reserve_fresh(out, n);  // engine/huge_pages.h: first touch of 112 B an answer
    out.assign(n, PointAnswer{});
    const bool signs =
        options.query == PointQuery::signed_distance || options.query == PointQuery::occupancy;
    const double reach = signs ? kInfinity : options.max_distance;
    const std::vector<std::uint32_t> order =
        options.spatial_order ? spatial_order(points.data(), n) : std::vector<std::uint32_t>{};
    // Before the loop, so that every worker can help (intersect.h); not for a batch whose token
    // has fired already (fired() reads the state: the loop's blocks do the checking).
    if (n >= kSpatialOrderMin && !options.cancel.fired())
        engine.build_point_tree();
    for_each_point(
        n, options.cancel, order,
        [&](std::size_t i) {
            auto h = engine.closest_point(points[i], reach);
            if (!h)
                return;
            out[i].hit = as_reported(*h, points[i]);
            out[i].distance = out[i].hit.distance;
        },
        [&](std::size_t i) {
            __builtin_prefetch(&points[i]);
            // A PointAnswer spans two cache lines.
            __builtin_prefetch(&out[i], 1);
            __builtin_prefetch(reinterpret_cast<const char*>(&out[i]) + 64, 1);
        });
    if (options.cancel.fired())
        return options.cancel.status();
    if (!signs)
        return {};
    // classify_points reads the error bound: the reported hit keeps it (distance 0 ≤ err). It
    // reads the hits where the answers hold them, and the answers are completed in parallel:
    // serial, copying 1M hits out and the verdicts back took ~6% of a signed distance's wall
    // time on A's shell.
    std::vector<Occupancy> occ(n);
    const Status st = classify_points(
        engine, points.data(), NearestHits::members(out.data(), &PointAnswer::hit), n,
        options.query == PointQuery::occupancy, options.cancel, occ.data(), order);
    if (!st.ok())
        return st;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 16384),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t i = r.begin(); i < r.end(); ++i) {
                              out[i].inside = occ[i].inside;
                              out[i].winding = occ[i].winding;
                              if (occ[i].inside && out[i].distance > 0.0)
                                  out[i].distance = -out[i].distance;
                          }
                      });
    return {};
}

}  // namespace raycastd::engine
