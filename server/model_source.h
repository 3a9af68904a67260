#pragma once
// Building engine scenes from what clients send: scene documents whose `mesh` objects name
// files (under the scene root, or saved copies when a registered scene is reloaded) or carry
// them inline, and whole model files posted as the body; telling which of them a body is; and
// preparing the result for queries (ModelSource) within the configured limits.

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "engine/load/model_loader.h"
#include "engine/query/intersect.h"
#include "engine/scene/scene.h"
#include "server/config.h"
#include "server/scene_cache.h"
#include "server/schema/json_read.h"
#include "server/uri_resolver.h"

namespace raycastd::server {

/// Reads a file by its normalised path relative to the scene root.
using FileSource = std::function<engine::Result<std::string>(const std::string& path)>;

/// Everything needed to (re)build a registered scene.
struct SceneSource {
    std::string content_type;  ///< "application/json" for scene documents, else a model type
    std::string body;
};

/// Builds prepared scenes within the configured limits: registered scenes from their source,
/// and the inline documents of stateless calls (the last 32 kept, keyed by content).
class ModelSource {
  public:
    ModelSource(const Limits& limits, std::string scene_root);

    /// Reads files under the scene root (confined; see uri_resolver.h).
    FileSource scene_root_files() const;
    /// A prepared scene from a registry source, reading the files it names through `files`
    /// (the registry's Builder). ApiError on any problem: bad_json, invalid_scene,
    /// unsupported_format, model_load_failed, too_large (over max_triangles too).
    std::shared_ptr<const engine::QueryEngine> build_scene(const SceneSource& source,
                                                           const FileSource& files) const;
    /// The inline "scene" of a stateless call's body (/v1/intersect, /v1/explain), prepared or
    /// reused from the cache: invalid_request when the body is not an object or has no
    /// "scene"; the scene's own errors as build_scene's, with paths under /scene. Once `cancel`
    /// fires (asked before and during the BVH build) the build stops and ApiError timeout is
    /// thrown; the caller asks the token what it means (request_cancel.h).
    std::shared_ptr<const engine::QueryEngine> build_stateless_scene(
        const Json& body, const engine::CancelToken& cancel = {}) const;
    /// Stateless calls answered from the cache.
    std::size_t stateless_cache_hits() const { return stateless_cache_.hits(); }

  private:
    Limits limits_;
    SceneRoot scene_root_;
    mutable SceneCache stateless_cache_{32};
};

/// What a POST /v1/scenes body is: "application/json" for a scene document (and for an empty
/// body, which parse_json reports), or the model content type of a raw model, told by the bytes
/// when `content_type` is absent or generic (octet-stream, form-urlencoded, text/plain);
/// unsupported_format otherwise.
std::string classify_scene_body(std::string_view body, const std::string& content_type);

/// Parses a scene document, loading its mesh objects through `files`. ApiError on any problem
/// (paths start with `prefix`): invalid_scene for the document, unsupported_format for a model
/// format we do not read, model_load_failed (422) for a file that cannot be used, too_large.
/// `textures` false: no texture is decoded (a scene only queried, never rendered).
engine::Scene scene_from_document(const Json& doc, const std::string& prefix,
                                  const FileSource& files, const Limits& limits,
                                  bool textures = true);

/// A whole model file as a scene: one object per part (glTF mesh instance, or the file), with
/// the model's materials, lights and camera.
engine::Scene scene_from_model(std::string_view bytes, engine::ModelFormat format,
                               const std::string& display_name, const Limits& limits);

/// The model format a request Content-Type names (model/gltf-binary, model/gltf+json,
/// model/obj, application/sla, model/stl, application/x-ply, model/x-ply, model/off, ...).
std::optional<engine::ModelFormat> format_from_content_type(const std::string& content_type);

/// RFC 4648 §4 base64 (whitespace ignored); nullopt when malformed.
std::optional<std::string> decode_base64(std::string_view text);

}  // namespace raycastd::server
