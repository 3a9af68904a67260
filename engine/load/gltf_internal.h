#pragma once
// Internal to engine/load: what the glTF loader's translation units share. This header
// includes tinygltf, so no public header may include it (model_loader.h hides the backend).

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

// tinygltf's header lives in /usr/include and is compiled as a system header, so its own
// warnings do not reach -Werror; no pragmas are needed around it.
#include <tiny_gltf.h>

#include "engine/load/model_loader.h"
#include "engine/math/transform.h"
#include "engine/scene/camera.h"
#include "engine/scene/light.h"
#include "engine/scene/material.h"
#include "engine/status.h"

namespace raycastd::engine::gltf {

/// The value of a hexadecimal digit, −1 for any other character (URI percent-escapes).
inline int hex_digit(char c) {
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

/// How a material's texture coordinates are read: the TEXCOORD_<texcoord> set, mapped by the
/// KHR_texture_transform affine map `matrix` (row-major 2×3: u' = m0·u + m1·v + m2,
/// v' = m3·u + m4·v + m5). texcoord −1: the material is not textured, so its primitives need
/// no texture coordinates.
struct UvMapping {
    int texcoord = -1;
    std::array<double, 6> matrix{1, 0, 0, 0, 1, 0};
};

/// Gives materials[i] the decoded base-colour texture of glTF material i (gltf_textures.cpp):
/// each image decoded once, from a bufferView, a base64 data: URI or a file read through
/// `read`, checked against limits.max_texture_pixels before decoding. A texture that cannot
/// be used is a warning, and the material keeps its factor alone. Returns each material's
/// UvMapping. Requires validate_buffers() to have passed.
std::vector<UvMapping> attach_base_color_textures(const tinygltf::Model& model,
                                                  const ResourceReader& read,
                                                  const LoadLimits& limits,
                                                  std::vector<Material>& materials,
                                                  std::vector<std::string>& warnings,
                                                  std::size_t& decoded_pixels);

/// Per glTF material, the mean (metallic, roughness) of its metallicRoughnessTexture's image
/// (B and G channels, linear, over all texels), which the factors multiply; none where it has
/// no such texture, where the image cannot be used (a warning), or where limits.textures is
/// false. The texture is not sampled per hit: its mean stands for the surface, where the factor
/// alone (glTF's default 1, left so because the texture carries the values) had made
/// TwoSidedPlane.gltf's wood a rough metal, black under the headlight. Decoded images count in
/// `decoded_pixels` against limits.max_texture_pixels_total and are not kept.
std::vector<std::optional<std::array<double, 2>>> metallic_roughness_means(
    const tinygltf::Model& model, const ResourceReader& read, const LoadLimits& limits,
    std::size_t& decoded_pixels, std::vector<std::string>& warnings);

/// Instances every mesh of the default scene (else scene 0, else every root node) with its
/// world transform into out.parts, and fills materials, lights, camera and warnings
/// (gltf_build.cpp). Requires validate_buffers() to have passed. Errors are model_load_failed
/// (bad reference, index out of range, node cycle or shared child, hierarchy deeper than 256)
/// or too_large; messages carry a JSON pointer but not the model's name.
Status build_model(const tinygltf::Model& model, std::string_view name, const ResourceReader& read,
                   const LoadLimits& limits, LoadedModel& out);

/// Checks every bufferView against its buffer, and every accessor (with its sparse indices and
/// values) against its bufferView, before any of them is read: offset + (count − 1)·stride +
/// element size ≤ byteLength, with overflow-checked arithmetic (glTF 2.0 §3.6.2.4, §5.1,
/// §5.11). Returns the first violation as model_load_failed, naming the JSON pointer.
Status validate_buffers(const tinygltf::Model& model);

/// The accessor's elements as doubles, `components` per element, with normalized integers
/// decoded as glTF 2.0 §3.11 specifies and sparse substitution applied (§3.6.2.3). Fails when
/// the accessor does not exist or has another number of components. Requires
/// validate_buffers() to have passed.
Result<std::vector<double>> read_floats(const tinygltf::Model& model, int accessor, int components,
                                        const std::string& what);

/// An index accessor's values (SCALAR of unsigned byte, short or int; glTF 2.0 §3.7.2.1).
/// Requires validate_buffers() to have passed.
Result<std::vector<std::uint32_t>> read_indices(const tinygltf::Model& model, int accessor,
                                                const std::string& what);

/// A node's local transform: its `matrix`, else T·R·S from translation / rotation / scale
/// (glTF 2.0 §3.5.3). Fails on a malformed matrix or TRS array or a non-finite value.
Result<Transform> local_transform(const tinygltf::Node& node, int index);

/// The Phong approximation of a metallic-roughness material (see gltf_scene.cpp for the
/// mapping and its sources).
Material to_phong(const tinygltf::Material& material,
                  const std::optional<std::array<double, 2>>& metallic_roughness = std::nullopt);

/// A pinhole camera from a perspective camera placed by `world` (glTF cameras look down their
/// local −Z with +Y up, glTF 2.0 §3.10.1). nullopt for orthographic or malformed cameras.
std::optional<Camera> to_camera(const tinygltf::Camera& camera, const Transform& world);

/// The `KHR_lights_punctual` light index a node carries, −1 for none, or an error when the
/// extension object is malformed or names a light that does not exist.
Result<int> node_light(const tinygltf::Node& node, int index, std::size_t light_count);

/// A KHR_lights_punctual light placed by `world`, with its raw radiometric colour (colour ×
/// intensity); spot lights become point lights and add a warning. nullopt (with a warning) for
/// an unknown light type.
std::optional<Light> to_light(const tinygltf::Light& light, const Transform& world,
                              std::vector<std::string>& warnings);

/// Rescales light intensities so the brightest component is at most 1, keeping their ratios
/// (our Phong lights have no distance falloff; see gltf_scene.cpp).
void normalize_light_intensities(std::vector<Light>& lights);

}  // namespace raycastd::engine::gltf
