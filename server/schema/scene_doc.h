#pragma once
// The scene document of docs/api.md ("Scene document") → engine::Scene. Every error is an ApiError
// whose path is the JSON pointer of the offending field (prefixed, e.g. "/scene" in the
// stateless calls). Unknown keys are not errors (clients may carry their own metadata) but are
// listed in the scene's warnings, so a typo such as "difuse" does not pass unnoticed.

#include <functional>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "engine/scene/scene.h"
#include "server/schema/json_read.h"

namespace raycastd::server {

/// Turns a `mesh` object (its JSON and pointer) into a world-space triangle mesh, appending any
/// materials it brings to `scene` (and setting per-triangle material indices). Throws ApiError.
using MeshObjectLoader = std::function<std::shared_ptr<const engine::TriangleMesh>(
    const Json& object, const std::string& path, engine::Scene& scene)>;

/// A camera object {position, look_at, up, fov_y_deg} (defaults for what is missing); errors
/// are `code` (invalid_scene in documents, invalid_request in render requests) with pointers.
engine::Camera parse_camera(const Json& j, const std::string& path, ErrorCode code);

/// Adds "unknown key <path>/<key> ignored" to the scene's warnings for each key of object `j`
/// not in `known` (docs/api.md: unknown keys are not errors, but typos must not pass silently).
void warn_unknown_keys(const Json& j, const std::string& path,
                       std::initializer_list<const char*> known, engine::Scene& scene);

/// The summary's name of a default view: "-z" or "+z", the side of the bounds the default
/// camera stands on (docs/api.md, "POST /v1/scenes").
const char* default_view_name(engine::DefaultView view);
/// The view a name of default_view_name gives; nullopt for any other string.
std::optional<engine::DefaultView> default_view_from_name(std::string_view name);

/// Parses and validates a scene document. `load_mesh` may be empty, in which case `mesh`
/// objects are rejected with invalid_scene.
engine::Scene parse_scene_doc(const Json& doc, const std::string& path_prefix,
                              const MeshObjectLoader& load_mesh);

}  // namespace raycastd::server
