#pragma once
// Intersect requests and responses (docs/api.md, "POST /v1/scenes/{id}/intersect"), in JSON.

#include <cstdint>
#include <string>
#include <vector>

#include "engine/query/intersect.h"
#include "engine/scene/scene.h"
#include "server/schema/json_read.h"

namespace raycastd::server {

/// Which parts of a hit record the client asked for (API `fields`; default: all).
struct FieldMask {
    bool t = true, t_err = true, point = true, normal = true, front_face = true, object = true,
         name = true, primitive = true, barycentric = true;

    /// Whether the engine must compute normals: for themselves, for front_face, and for point,
    /// since a far sphere hit's point is c + r·n with the hit's own normal (engine::hit_point).
    bool needs_normals() const { return normal || front_face || point; }
};

struct IntersectRequest {
    std::vector<engine::Ray> rays;
    engine::QueryOptions options;
    FieldMask fields;
};

/// Parses {"rays": [...], "mode", "precision", "fields"}; `prefix` is the pointer of the
/// object holding them (empty for a whole body). Ray errors are invalid_ray naming the index;
/// more than `max_rays` rays is too_large.
IntersectRequest parse_intersect_request(const Json& body, const std::string& prefix,
                                         std::size_t max_rays);

engine::Mode parse_mode(const std::string& s, const std::string& path);
/// The `fields` array (invalid_request naming the unknown entry).
FieldMask parse_fields(const Json& j, const std::string& path);
/// The same names as a comma-separated list (the binary form's `?fields=t,object`); an empty
/// list asks for none, an empty or unknown entry is invalid_request at `path`.
FieldMask parse_field_list(const std::string& list, const std::string& path);
engine::Precision parse_precision(const std::string& s, const std::string& path);

/// {"precision": ..., "hits": [...]} with the record shape of the mode, for `result` of
/// `engine` (its scene's names, and its points: QueryEngine::point_of).
std::string write_intersect_response(const engine::QueryEngine& engine, const IntersectRequest& req,
                                     const engine::QueryResult& result);

}  // namespace raycastd::server
