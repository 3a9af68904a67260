#pragma once
// The point queries of the API (docs/api.md, POST /v1/scenes/{id}/points) over one prepared
// scene: the closest surface point, the unsigned and the signed distance, and occupancy.
//
//   closest          QueryEngine::closest_point: the exact closest point in double, ties to the
//                    lower object, then the lower primitive (geometry/closest_point.h);
//   distance         its distance;
//   signed_distance  the distance, negated when the point is inside any solid of the scene;
//   occupancy        inside or not, and the winding number (inside.h says how each object
//                    decides: spheres exactly, `parity` meshes by crossing parity on the exact
//                    ray path, `winding` meshes by the fast generalized winding number).
// A point within the error bound of a surface (ClosestPoint::err: 16 ulps of the coordinates'
// magnitude) is on it: distance 0, its closest point is the point itself, and it is inside.
// Batches run in parallel (TBB); the answer of each point does not depend on the others.

#include <optional>
#include <string_view>
#include <vector>

#include "engine/cancel.h"
#include "engine/query/intersect.h"

namespace raycastd::engine {

/// What a points request asks of each point.
enum class PointQuery { closest, distance, signed_distance, occupancy };

/// "closest", "distance", "signed_distance", "occupancy".
const char* to_string(PointQuery q);
/// The query a name denotes; nullopt for an unknown name.
std::optional<PointQuery> point_query_from_string(std::string_view name);

struct PointOptions {
    PointQuery query = PointQuery::closest;
    /// closest and distance: surfaces farther than this are not found (inclusive). The signed
    /// distance and occupancy always look at the whole scene.
    double max_distance = kInfinity;
    /// Asked once per block of 256 points (and by the parity rays' batch); once it fires, the
    /// rest is skipped and query_points answers Code::cancelled.
    CancelToken cancel{};
    /// Whether a large batch is taken in its spatial order (batch.h: near points one after the
    /// other, so the trees they walk stay in cache). The answers are the same either way; false
    /// is for measuring what the order gains (bench_points' "given order" rows).
    bool spatial_order = true;
};

/// One point's answer; which fields mean something depends on the query.
struct PointAnswer {
    /// closest: the nearest surface point within max_distance (!valid(): none).
    PointHit hit;
    /// distance and signed_distance: the distance to the nearest surface (+inf when there is none
    /// within reach), negative inside for signed_distance; 0 on a surface.
    double distance = kInfinity;
    /// occupancy: the largest winding number over the objects (1 or 0 for spheres and parity
    /// meshes; 1 on a surface).
    double winding = 0.0;
    /// signed_distance and occupancy: inside some solid of the scene (or on a surface).
    bool inside = false;
};

/// Answers every point; points must be finite (the server checks). `out` is resized to match.
/// ok, or Code::cancelled once options.cancel has fired (`out` then holds partial answers).
Status query_points(const QueryEngine& engine, const std::vector<Vec3d>& points,
                    const PointOptions& options, std::vector<PointAnswer>& out);

}  // namespace raycastd::engine
