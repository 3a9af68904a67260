#pragma once
// Model loading: glTF 2.0 (.gltf, .glb), OBJ (+MTL), PLY, STL and OFF bytes → engine meshes,
// materials, lights and a camera, all in world space and double precision.
//
// The loaders never touch the file system: what a model refers to (external glTF buffers, OBJ
// material libraries) is fetched through the caller's ResourceReader, which the server confines
// to its scene root, and so are the images of base-colour textures (PNG, JPEG). The glTF backend
// (tinygltf) is hidden behind this header; OBJ, PLY, STL and OFF have small readers of their own.
// Errors come back as Status values and nothing is thrown across this API.

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "engine/geometry/mesh.h"
#include "engine/math/transform.h"
#include "engine/scene/camera.h"
#include "engine/scene/light.h"
#include "engine/scene/material.h"
#include "engine/status.h"

namespace raycastd::engine {

enum class ModelFormat { gltf, glb, obj, ply, stl, off };

/// The format named by "gltf", "glb", "obj", "ply", "stl" or "off" (any case), or by a file
/// name ending in one of those extensions ("models/Duck.GLB"); nullopt for anything else.
std::optional<ModelFormat> format_from_name(std::string_view name_or_ext);

/// The format the bytes look like: "glTF" magic → glb, leading '{' → gltf, "ply" line → ply,
/// "OFF"-family header → off, "solid" → ASCII STL unless the size matches the binary STL rule
/// (80-byte header + uint32 count n + 50·n bytes), which also identifies binary STL with any
/// header. OBJ has no signature: nullopt (and nullopt for anything unrecognised).
std::optional<ModelFormat> sniff_format(std::string_view bytes);

/// The lower-case extension naming a format ("glb", ...).
std::string_view format_name(ModelFormat format);

/// Reads a file referenced by a model (external .bin buffers, .mtl) by its URI relative to the
/// model, already percent-decoded; returns its bytes or a Status. The server supplies
/// one confined to its scene root. The loader itself refuses URIs with a scheme (http:, file:,
/// ...) and absolute paths before calling it.
using ResourceReader = std::function<Result<std::string>(const std::string& uri)>;

/// A ResourceReader that refuses everything (for models that must be self-contained, such as
/// inline data_base64 uploads).
ResourceReader no_resources();

/// One glTF mesh instance (a node with a mesh) or one whole OBJ/PLY/STL/OFF file.
struct ModelPart {
    /// glTF: the node's name, else the mesh's name, else "<display_name> mesh <k>" (k counts
    /// parts from 1). Other formats: display_name.
    std::string name;
    /// Positions in world space (node transforms applied). Triangles are numbered in file order:
    /// glTF primitives in order, strips and fans converted as glTF 2.0 §3.7.2.1 lists them;
    /// polygons of the other formats fan-triangulated as (v0, vi, vi+1). Vertices are kept as
    /// the file lists them (unreferenced ones included), except that STL, which stores every
    /// corner separately, has exactly equal corners merged. glTF morph targets are applied at
    /// their default weights; skinned meshes are posed by their joints in the
    /// file's rest pose (linear blend skinning, no animation). normals is per-vertex when every
    /// primitive of the part has normals, else empty (never computed). triangle_material is empty
    /// when no triangle of the part names a material; otherwise it has one index per triangle into
    /// LoadedModel::materials, and triangles without a material of their own use an appended grey
    /// "default" material. corner_uvs is filled when some triangle's material is textured and its
    /// primitive (glTF) or its face (OBJ) gives texture coordinates, with (0, 0) for the other
    /// triangles.
    TriangleMesh mesh;
};

/// Everything a model file brings into a scene.
struct LoadedModel {
    std::vector<ModelPart> parts;
    std::vector<Material> materials;          ///< indexed by triangle_material
    std::vector<std::string> material_names;  ///< same length as materials
    /// Point and directional lights only (no ambient); glTF intensities are colour × intensity,
    /// rescaled together so the brightest component is at most 1 (see gltf_scene.cpp).
    std::vector<Light> lights;
    std::optional<Camera> camera;       ///< the first perspective camera, if any
    std::vector<std::string> warnings;  ///< what was skipped or approximated, and why

    /// Sum of the parts' triangle counts.
    std::size_t triangle_count() const;
};

/// Safety limits for one load; exceeding one is Code::too_large.
struct LoadLimits {
    /// Triangles over all parts (glTF instancing can multiply a small file's triangles).
    std::size_t max_triangles = 50'000'000;
    /// Vertices over all parts.
    std::size_t max_vertices = 50'000'000;
    /// Pixels of one texture image, checked from its header before it is decoded; a larger
    /// image is dropped with a warning (the material keeps its factor alone).
    std::size_t max_texture_pixels = 16'777'216;
    /// Pixels of all the texture images of one model together (a file of many small PNGs can
    /// each declare the most one image may have): images past it are dropped the same way.
    std::size_t max_texture_pixels_total = 4 * 16'777'216;
    /// False: base-colour textures are neither read nor decoded (a scene that is only queried,
    /// never rendered, as the server's stateless calls are), and nothing is said of them.
    bool textures = true;
};

/// Parses `bytes` as `format`. display_name names the parts and appears in messages (a file
/// name or the scene object's name). Errors: Code::model_load_failed with the reason (index out
/// of range, accessor past its buffer view, byteLength that lies, truncated GLB, node cycle,
/// unknown required extension, ...), Code::unsupported_format for a variant we do not read,
/// Code::too_large past `limits`. Never throws, never reads outside `bytes` or through anything
/// but `read_resource`.
Result<LoadedModel> load_model(std::string_view bytes, ModelFormat format,
                               const ResourceReader& read_resource, std::string_view display_name,
                               const LoadLimits& limits = {});

/// Applies `t` to everything in `model`: positions (as points), normals (by the inverse
/// transpose), point-light positions, directional-light directions and the camera. When t
/// mirrors (negative determinant) every triangle's winding is reversed, so that front faces stay
/// counter-clockwise (glTF 2.0 §3.7.2.1 states the same rule for node transforms).
void apply_transform(LoadedModel& model, const Transform& t);

}  // namespace raycastd::engine
