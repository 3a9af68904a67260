#pragma once
// Internal to engine/load: one entry point per format, called by load_model() inside its
// catch-all boundary, and the helpers they share.

#include <cctype>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "engine/load/model_loader.h"
#include "engine/scene/texture.h"

namespace raycastd::engine::detail {

/// glTF 2.0, JSON (`binary` false) or GLB container (`binary` true).
Result<LoadedModel> load_gltf(std::string_view bytes, bool binary, const ResourceReader& read,
                              std::string_view name, const LoadLimits& limits);
/// Wavefront OBJ with its MTL libraries (own reader; see obj_reader.cpp for why).
Result<LoadedModel> load_obj(std::string_view bytes, const ResourceReader& read,
                             std::string_view name, const LoadLimits& limits);
/// PLY, ASCII or binary little/big-endian (own reader; see ply_reader.cpp for why).
Result<LoadedModel> load_ply(std::string_view bytes, std::string_view name,
                             const LoadLimits& limits);
/// STL, ASCII or binary (own reader; see stl_off_reader.cpp).
Result<LoadedModel> load_stl(std::string_view bytes, std::string_view name,
                             const LoadLimits& limits);
/// Object File Format (ASCII OFF, COFF, NOFF, STOFF and their combinations).
Result<LoadedModel> load_off(std::string_view bytes, std::string_view name,
                             const LoadLimits& limits);

/// ASCII lower case (file extensions, format keywords).
inline std::string lower(std::string_view s) {
    std::string out(s);
    for (char& c : out)
        c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return out;
}

/// model_load_failed with "<name>: <message>".
Status load_error(std::string_view name, const std::string& message);
/// `status` with "<name>: " put in front of its message.
Status with_name(std::string_view name, Status status);

/// Refuses a resource URI that is not a plain relative path: a scheme ("http:", "file:",
/// "data:" reaching the file system, a Windows drive "C:"), an absolute path ("/x", "\x"),
/// or an empty string. Confinement within the scene root is the ResourceReader's job.
Status check_resource_uri(std::string_view uri);

/// Appends polygon `poly` (vertex indices, already validated against the vertex count) to
/// `mesh` as the fan (v0, vi, vi+1), i = 1..n−2, in that order, and returns how many
/// triangles that is (0 for fewer than 3 vertices). Fan triangulation is exact for convex
/// polygons; a concave polygon gets overlapping triangles, as in every fan-based reader.
std::size_t add_fan(TriangleMesh& mesh, const std::vector<std::uint32_t>& poly);

/// A PNG or JPEG texture image decoded to 8-bit sRGB RGB (texture_image.cpp). The width ×
/// height its header declares is checked against limits.max_texture_pixels, and, with the
/// `decoded` pixels of the model's images so far, against limits.max_texture_pixels_total,
/// before anything is decoded; `decoded` grows by the image's pixels. Errors
/// (model_load_failed) carry a reason for the caller's warning: not PNG/JPEG, an unreadable
/// header, over a limit, or pixels that do not decode.
Result<std::shared_ptr<const TextureImage>> decode_texture_image(std::string_view bytes,
                                                                 const LoadLimits& limits,
                                                                 std::size_t& decoded);

/// Checks shared by every format once the parts are built: finite positions (model_load_failed
/// naming the part and vertex), finite normals (dropped with a warning otherwise), the limits
/// (too_large), and a warning when the model has no triangles at all.
Status finish_model(LoadedModel& model, std::string_view name, const LoadLimits& limits);

}  // namespace raycastd::engine::detail
