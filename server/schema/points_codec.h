#pragma once
// The binary form of the points request (docs/api.md): packed little-endian records, no header,
// no padding, floats of the request's dtype (?dtype=float32|float64).
//   request:                     N × {x y z}
//   closest:                     N × {px py pz distance, object u32, primitive u32, u v}
//                                (not found: distance = +inf, ids 0xFFFFFFFF, the rest 0)
//   distance, signed_distance:   N × {d}          (+inf where nothing is within reach)
//   occupancy:                   N × {winding}    (1 on a surface; inside is winding ≥ ½)

#include <string>
#include <string_view>
#include <vector>

#include "engine/points/point_queries.h"
#include "server/schema/binary_codec.h"

namespace raycastd::server {

/// Bytes of one request record: 12 (float32) or 24 (float64).
inline std::size_t point_record_bytes(Dtype d) {
    return d == Dtype::float32 ? 12 : 24;
}

/// Bytes of one answer record of `query`.
std::size_t point_answer_bytes(engine::PointQuery query, Dtype dtype);

/// Decodes the body into `points` (capacity reused). invalid_request for a length that is not a
/// whole number of records and for a NaN or infinite coordinate, naming the lowest such point's
/// index (/points/i); too_large over max_points.
void decode_points(std::string_view body, Dtype dtype, std::size_t max_points,
                   std::vector<engine::Vec3d>& points);

/// Encodes the answers of `query` into `out` (cleared; capacity reused).
void encode_point_answers(const std::vector<engine::PointAnswer>& answers, engine::PointQuery query,
                          Dtype dtype, std::string& out);

}  // namespace raycastd::server
