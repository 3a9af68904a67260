#pragma once
// The ray scanner: the fast reader for the body of POST /v1/scenes/{id}/intersect. A
// hand-written scanner reads rays straight into engine::Ray values, numbers through
// std::from_chars, without building a JSON DOM (a DOM round trip through nlohmann capped near
// 0.25 Mrays/s; nlohmann's SAX lexer, used here before, still spent 55% of a 10,000-ray request
// scanning numbers; docs/benchmarks.md).
//
// It accepts exactly the well-formed shape, with plain-ASCII strings. On anything else — a
// syntax error, a field of the wrong type, an escape in a string, a number out of range — it
// gives up, and the caller parses the body again with the DOM reader, whose errors (with JSON
// pointers) are the reference. So the fast path can never change an answer or an error, only
// the time it takes (ray_scanner_test.cpp compares the two bit for bit).

#include <string_view>

#include "server/schema/query_doc.h"

namespace raycastd::server {

/// Parses `body` into `out` (ray count limited by max_rays, rays validated) when it has the
/// expected shape; false when the caller must fall back to the DOM reader. May throw the same
/// ApiErrors as parse_intersect_request for a well-formed body (invalid_ray, too_large, ...).
bool scan_intersect_request(std::string_view body, std::size_t max_rays, IntersectRequest& out);

}  // namespace raycastd::server
