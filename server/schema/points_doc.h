#pragma once
// Points requests and responses in JSON (docs/api.md, "POST /v1/scenes/{id}/points"):
//   {"points": [[x, y, z], ...], "query": "closest", "max_distance": 1e30}
//   → {"query": "closest", "results": [one entry per point, in order]}
// with the entry shapes of the query: closest {"found": true, "point", "distance", "object",
// "name", "primitive", "barycentric", "normal"} or {"found": false}; distance and
// signed_distance {"distance": d} (null when no surface is within reach); occupancy
// {"inside": bool, "winding": w}. The binary form is points_codec.h.

#include <string>
#include <vector>

#include "engine/points/point_queries.h"
#include "server/schema/json_read.h"

namespace raycastd::server {

struct PointsRequest {
    std::vector<engine::Vec3d> points;
    engine::PointOptions options;
};

/// Parses the request object at `prefix` (empty for a whole body). A point that is not three
/// numbers is invalid_request naming its index (/points/i); more than max_points is too_large; a
/// number JSON cannot hold (1e999) is bad_json, as everywhere.
PointsRequest parse_points_request(const Json& body, const std::string& prefix,
                                   std::size_t max_points);

/// "closest", "distance", "signed_distance" or "occupancy"; invalid_request otherwise, at `path`.
engine::PointQuery parse_point_query(const std::string& name, const std::string& path);
/// A max_distance: a number ≥ 0 (invalid_request otherwise, at `path`).
double parse_max_distance(double value, const std::string& path);

/// The JSON response for the answers of `query`, one entry per point.
std::string write_points_response(const engine::Scene& scene, engine::PointQuery query,
                                  const std::vector<engine::PointAnswer>& answers);

}  // namespace raycastd::server
