#pragma once
// Render and trace requests and responses (docs/api.md and docs/rendering.md, "POST
// /v1/scenes/{id}/render" and "POST /v1/scenes/{id}/trace"), and the single ray of trace and
// explain.

#include <string>

#include "engine/render/render.h"
#include "engine/shade/whitted.h"
#include "server/schema/json_read.h"

namespace raycastd::server {

struct RenderRequest {
    engine::RenderOptions options;
    engine::ImageFormat format = engine::ImageFormat::png;
    bool async = false;
};

/// Parses a render body (null or {} gives every default: 640 × 480, spp 1, max_depth 5, phong,
/// lighting auto, png, fast). invalid_request names the offending field; an unknown `format` is
/// unsupported_format; width × height × spp over `max_pixels` is too_large.
RenderRequest parse_render_request(const Json& body, std::size_t max_pixels);

struct TraceRequest {
    engine::Ray ray;
    engine::WhittedOptions options;
};

/// Parses {"ray": {...}, "max_depth": 5, "precision": "refined"}.
TraceRequest parse_trace_request(const Json& body);

/// The member "ray" of `body` ({"origin", "direction", "tmin"?, "tmax"?}) checked by the API's
/// ray rules: invalid_request when absent, invalid_ray naming the field otherwise.
engine::Ray parse_single_ray(const Json& body, const std::string& path);

/// {"tree": node | null, "summary": {...}, "rays": {...}, "precision": ...}: nodes labelled I1,
/// I2, … depth-first (reflected before refracted), shadow rays naming their blocker.
std::string write_trace_json(const engine::Scene& scene, const engine::RayTree& tree,
                             engine::Precision precision);

/// The X-Rays header value: "primary=N, shadow=N, reflected=N, refracted=N".
std::string rays_header(const engine::RayCounts& counts);

}  // namespace raycastd::server
