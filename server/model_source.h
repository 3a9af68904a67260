#pragma once
// Building engine scenes from what clients send: scene documents whose `mesh` objects name
// files (under the scene root, or saved copies when a registered scene is reloaded) or carry
// them inline, and whole model files posted as the body.

#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "engine/load/model_loader.h"
#include "engine/scene/scene.h"
#include "server/config.h"
#include "server/schema/json_read.h"

namespace raycastd::server {

/// Reads a file by its normalised path relative to the scene root.
using FileSource = std::function<engine::Result<std::string>(const std::string& path)>;

/// Parses a scene document, loading its mesh objects through `files`. ApiError on any problem
/// (paths start with `prefix`): invalid_scene for the document, unsupported_format for a model
/// format we do not read, model_load_failed (422) for a file that cannot be used, too_large.
engine::Scene scene_from_document(const Json& doc, const std::string& prefix,
                                  const FileSource& files, const Limits& limits);

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
