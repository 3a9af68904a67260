// glTF scene graph → world-space parts: node hierarchy checks and traversal, primitive
// assembly (indices, strips, fans, morph targets at their default weights), instancing.

#include <algorithm>
#include <limits>
#include <map>

#include "engine/load/gltf_internal.h"

namespace raycastd::engine::gltf {

namespace {

constexpr std::size_t kMaxNodeDepth = 256;
constexpr std::uint32_t kNoMaterial = std::numeric_limits<std::uint32_t>::max();

Status fail(std::string msg) {
    return Status::error(Code::model_load_failed, std::move(msg));
}

bool in_range(int index, std::size_t size) {
    return index >= 0 && static_cast<std::size_t>(index) < size;
}

std::string node_path(std::size_t n) {
    return "/nodes/" + std::to_string(n);
}

/// One mesh's primitives in the mesh's own space, built once and instanced by every node that
/// uses it.
struct LocalMesh {
    std::vector<Vec3d> positions;
    std::vector<Vec3d> normals;  ///< parallel to positions; cleared unless every primitive has them
    std::vector<std::array<std::uint32_t, 3>> triangles;
    std::vector<std::uint32_t>
        materials;  ///< per triangle, kNoMaterial when the primitive has none
    bool any_material = false;
    /// Per triangle, (0, 0) where its primitive's material is not textured; kept only when
    /// some primitive's are (any_uvs).
    std::vector<std::array<std::array<float, 2>, 3>> corner_uvs;
    bool any_uvs = false;
};

struct Placed {
    int node = -1;
    Transform world;
};

/// glTF 2.0 §3.5.2: "the node hierarchy MUST be a set of disjoint strict trees" — no node is
/// the child of two parents and no node is its own ancestor. Checked in O(nodes) by walking up
/// parent links and remembering which nodes already reached a root.
Status check_hierarchy(const tinygltf::Model& m) {
    const std::size_t n = m.nodes.size();
    std::vector<int> parent(n, -1);
    for (std::size_t i = 0; i < n; ++i) {
        const tinygltf::Node& node = m.nodes[i];
        for (int c : node.children) {
            if (!in_range(c, n)) {
                return fail(node_path(i) + "/children refers to node " + std::to_string(c) +
                            ", but the file has " + std::to_string(n));
            }
            auto child = static_cast<std::size_t>(c);
            if (parent[child] != -1) {
                return fail(node_path(child) + " is a child of both node " +
                            std::to_string(parent[child]) + " and node " + std::to_string(i));
            }
            parent[child] = static_cast<int>(i);
        }
        if (node.mesh != -1 && !in_range(node.mesh, m.meshes.size())) {
            return fail(node_path(i) + "/mesh refers to mesh " + std::to_string(node.mesh) +
                        ", but the file has " + std::to_string(m.meshes.size()));
        }
        if (node.camera != -1 && !in_range(node.camera, m.cameras.size())) {
            return fail(node_path(i) + "/camera refers to camera " + std::to_string(node.camera) +
                        ", but the file has " + std::to_string(m.cameras.size()));
        }
    }
    enum : char { unknown, on_path, rooted };
    std::vector<char> state(n, unknown);
    std::vector<std::size_t> path;
    for (std::size_t start = 0; start < n; ++start) {
        path.clear();
        std::size_t at = start;
        while (state[at] == unknown) {
            state[at] = on_path;
            path.push_back(at);
            if (parent[at] == -1)
                break;
            at = static_cast<std::size_t>(parent[at]);
        }
        if (state[at] == on_path && parent[at] != -1) {
            return fail(node_path(at) + " is its own ancestor (node cycle)");
        }
        for (std::size_t p : path)
            state[p] = rooted;
    }
    return {};
}

/// The nodes to instance: the default scene's (glTF 2.0 §3.5.1), else scene 0's, else, when
/// the file has no scenes, every root node.
Result<std::vector<int>> scene_roots(const tinygltf::Model& m) {
    if (m.defaultScene != -1 && !in_range(m.defaultScene, m.scenes.size())) {
        return fail("/scene refers to scene " + std::to_string(m.defaultScene) +
                    ", but the file has " + std::to_string(m.scenes.size()));
    }
    std::vector<int> roots;
    if (!m.scenes.empty()) {
        const std::size_t s = m.defaultScene == -1 ? 0 : static_cast<std::size_t>(m.defaultScene);
        roots = m.scenes[s].nodes;
        for (int r : roots) {
            if (!in_range(r, m.nodes.size())) {
                return fail("/scenes/" + std::to_string(s) + "/nodes refers to node " +
                            std::to_string(r) + ", but the file has " +
                            std::to_string(m.nodes.size()));
            }
        }
        return roots;
    }
    std::vector<bool> is_child(m.nodes.size(), false);
    for (const auto& node : m.nodes) {
        for (int c : node.children)
            is_child[static_cast<std::size_t>(c)] = true;
    }
    for (std::size_t i = 0; i < m.nodes.size(); ++i) {
        if (!is_child[i])
            roots.push_back(static_cast<int>(i));
    }
    return roots;
}

/// Depth-first, parents before children, children in file order; world = parent · local
/// (glTF 2.0 §3.5.3). An explicit stack, so a deep hierarchy cannot exhaust the call stack.
Result<std::vector<Placed>> place_nodes(const tinygltf::Model& m, const std::vector<int>& roots) {
    struct Item {
        int node;
        Transform parent;
        std::size_t depth;
    };
    std::vector<Placed> placed;
    std::vector<Item> stack;
    for (auto r = roots.rbegin(); r != roots.rend(); ++r)
        stack.push_back({*r, Transform(), 1});
    while (!stack.empty()) {
        Item item = stack.back();
        stack.pop_back();
        if (item.depth > kMaxNodeDepth) {
            return fail("node hierarchy deeper than " + std::to_string(kMaxNodeDepth) + " levels");
        }
        const tinygltf::Node& node = m.nodes[static_cast<std::size_t>(item.node)];
        auto local = local_transform(node, item.node);
        if (!local)
            return local.status();
        Transform world = item.parent * *local;
        if (!world.is_finite())
            return fail(node_path(static_cast<std::size_t>(item.node)) +
                        ": world transform overflows");
        for (auto c = node.children.rbegin(); c != node.children.rend(); ++c) {
            stack.push_back({*c, world, item.depth + 1});
        }
        placed.push_back({item.node, world});
    }
    return placed;
}

/// Primitive topology → triangles (glTF 2.0 §3.7.2.1): TRIANGLES takes indices three at a
/// time; strip triangle i is (vᵢ, vᵢ₊₁₊ᵢ﹪₂, vᵢ₊₂₋ᵢ﹪₂), which alternates the order so every
/// triangle keeps the strip's winding; fan triangle i is (vᵢ₊₁, vᵢ₊₂, v₀).
void append_triangles(int mode, const std::vector<std::uint32_t>& idx, std::uint32_t base,
                      std::uint32_t material, LocalMesh& out) {
    auto add = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        out.triangles.push_back({base + a, base + b, base + c});
        out.materials.push_back(material);
    };
    const std::size_t n = idx.size();
    if (mode == TINYGLTF_MODE_TRIANGLES) {
        for (std::size_t i = 0; i + 2 < n; i += 3)
            add(idx[i], idx[i + 1], idx[i + 2]);
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
        for (std::size_t i = 0; i + 2 < n; ++i) {
            if (i % 2 == 0) {
                add(idx[i], idx[i + 1], idx[i + 2]);
            } else {
                add(idx[i], idx[i + 2], idx[i + 1]);
            }
        }
    } else {
        for (std::size_t i = 0; i + 2 < n; ++i)
            add(idx[i + 1], idx[i + 2], idx[0]);
    }
}

/// Adds weights[t] × target t's displacement of `attribute` to `values` (glTF 2.0 §3.7.2.2:
/// the rendered pose is the base plus the weighted sum of the targets).
Status apply_targets(const tinygltf::Model& m, const tinygltf::Primitive& prim,
                     const std::vector<double>& weights, const char* attribute,
                     const std::string& where, std::vector<double>& values) {
    for (std::size_t t = 0; t < prim.targets.size() && t < weights.size(); ++t) {
        auto it = prim.targets[t].find(attribute);
        if (it == prim.targets[t].end() || weights[t] == 0.0)
            continue;
        const std::string what = where + "/targets/" + std::to_string(t) + "/" + attribute;
        auto delta = read_floats(m, it->second, 3, what);
        if (!delta)
            return delta.status();
        if (delta->size() != values.size())
            return fail(what + " has a different count than the base attribute");
        for (std::size_t i = 0; i < values.size(); ++i)
            values[i] += weights[t] * (*delta)[i];
    }
    return {};
}

/// The primitive's NORMAL values, morphed like its positions; empty when it has none or when
/// their count differs from POSITION's (then with a warning).
Result<std::vector<double>> primitive_normals(const tinygltf::Model& m,
                                              const tinygltf::Primitive& prim,
                                              const std::vector<double>& weights,
                                              const std::string& where, std::size_t values,
                                              std::vector<std::string>& warnings) {
    auto it = prim.attributes.find("NORMAL");
    if (it == prim.attributes.end())
        return std::vector<double>{};
    auto normals = read_floats(m, it->second, 3, where + "/attributes/NORMAL");
    if (!normals)
        return normals.status();
    if (normals->size() != values) {
        warnings.push_back(where + ": NORMAL count differs from POSITION count; normals ignored");
        return std::vector<double>{};
    }
    if (Status st = apply_targets(m, prim, weights, "NORMAL", where, *normals); !st.ok())
        return st;
    return normals;
}

/// The primitive's vertex indices, each checked against the vertex count; 0..count−1 when the
/// primitive is not indexed.
Result<std::vector<std::uint32_t>> primitive_indices(const tinygltf::Model& m,
                                                     const tinygltf::Primitive& prim,
                                                     const std::string& where, std::size_t count) {
    std::vector<std::uint32_t> indices;
    if (prim.indices == -1) {
        indices.resize(count);
        for (std::size_t k = 0; k < count; ++k)
            indices[k] = static_cast<std::uint32_t>(k);
        return indices;
    }
    auto read = read_indices(m, prim.indices, where + "/indices");
    if (!read)
        return read.status();
    for (std::size_t k = 0; k < read->size(); ++k) {
        if ((*read)[k] >= count) {
            return fail(where + "/indices: value " + std::to_string((*read)[k]) + " at " +
                        std::to_string(k) + " is out of range for " + std::to_string(count) +
                        " vertices");
        }
    }
    return read;
}

/// Appends the corner texture coordinates of the triangles from `first` on: the primitive's
/// TEXCOORD_n set mapped by the material's UvMapping when its material is textured, else
/// (0, 0). A set that is missing or has another count than POSITION is a warning.
Status add_corner_uvs(const tinygltf::Model& m, const tinygltf::Primitive& prim,
                      const std::string& where, const UvMapping* mapping, std::uint32_t base,
                      std::size_t count, std::size_t first, LocalMesh& out,
                      std::vector<std::string>& warnings) {
    std::vector<double> uv;
    if (mapping && mapping->texcoord >= 0) {
        const std::string set = "TEXCOORD_" + std::to_string(mapping->texcoord);
        auto it = prim.attributes.find(set);
        if (it == prim.attributes.end()) {
            warnings.push_back(where + " has a textured material but no " + set +
                               "; drawn untextured");
        } else {
            auto read = read_floats(m, it->second, 2, where + "/attributes/" + set);
            if (!read)
                return read.status();
            if (read->size() != 2 * count) {
                warnings.push_back(where + ": " + set +
                                   " count differs from POSITION count; drawn untextured");
            } else {
                uv = std::move(*read);
                out.any_uvs = true;
            }
        }
    }
    for (std::size_t t = first; t < out.triangles.size(); ++t) {
        std::array<std::array<float, 2>, 3> corners{};
        if (!uv.empty()) {
            const auto& k = mapping->matrix;
            for (std::size_t c = 0; c < 3; ++c) {
                const std::size_t v = out.triangles[t][c] - base;
                const double u0 = uv[2 * v], v0 = uv[2 * v + 1];
                corners[c] = {static_cast<float>(k[0] * u0 + k[1] * v0 + k[2]),
                              static_cast<float>(k[3] * u0 + k[4] * v0 + k[5])};
            }
        }
        out.corner_uvs.push_back(corners);
    }
    return {};
}

Status add_primitive(const tinygltf::Model& m, std::size_t mesh, std::size_t p,
                     const std::vector<double>& weights, const std::vector<UvMapping>& uv_maps,
                     LocalMesh& out, bool& normals_complete, std::vector<std::string>& warnings) {
    const tinygltf::Primitive& prim = m.meshes[mesh].primitives[p];
    const std::string where =
        "/meshes/" + std::to_string(mesh) + "/primitives/" + std::to_string(p);
    if (prim.mode >= TINYGLTF_MODE_POINTS && prim.mode <= TINYGLTF_MODE_LINE_STRIP) {
        static const char* const kNames[] = {"POINTS", "LINES", "LINE_LOOP", "LINE_STRIP"};
        warnings.push_back(where + ": " + kNames[prim.mode] +
                           " primitive skipped (only triangles are ray-traced)");
        return {};
    }
    if (prim.mode < TINYGLTF_MODE_TRIANGLES || prim.mode > TINYGLTF_MODE_TRIANGLE_FAN) {
        return fail(where + "/mode " + std::to_string(prim.mode) + " is not a glTF primitive mode");
    }
    auto pos_it = prim.attributes.find("POSITION");
    if (pos_it == prim.attributes.end()) {
        warnings.push_back(where + " has no POSITION; skipped");
        return {};
    }
    if (prim.extensions.count("KHR_draco_mesh_compression") &&
        in_range(pos_it->second, m.accessors.size()) &&
        m.accessors[static_cast<std::size_t>(pos_it->second)].bufferView == -1) {
        warnings.push_back(where + " is Draco-compressed with no uncompressed fallback; skipped");
        return {};
    }
    auto positions = read_floats(m, pos_it->second, 3, where + "/attributes/POSITION");
    if (!positions)
        return positions.status();
    if (Status st = apply_targets(m, prim, weights, "POSITION", where, *positions); !st.ok())
        return st;
    const std::size_t count = positions->size() / 3;
    auto normals = primitive_normals(m, prim, weights, where, positions->size(), warnings);
    if (!normals)
        return normals.status();
    if (normals->empty())
        normals_complete = false;
    auto indices = primitive_indices(m, prim, where, count);
    if (!indices)
        return indices.status();
    if (prim.mode == TINYGLTF_MODE_TRIANGLES && indices->size() % 3 != 0) {
        warnings.push_back(where + ": " + std::to_string(indices->size() % 3) +
                           " trailing indices ignored (not a multiple of 3)");
    }
    if (prim.material != -1 && !in_range(prim.material, m.materials.size())) {
        return fail(where + "/material refers to material " + std::to_string(prim.material) +
                    ", but the file has " + std::to_string(m.materials.size()));
    }
    const std::uint32_t material =
        prim.material == -1 ? kNoMaterial : static_cast<std::uint32_t>(prim.material);
    out.any_material = out.any_material || prim.material != -1;
    if (out.positions.size() + count > std::numeric_limits<std::uint32_t>::max()) {
        return Status::error(Code::too_large, where + ": more than 2³² vertices in one mesh");
    }
    const auto base = static_cast<std::uint32_t>(out.positions.size());
    const std::vector<double>& pos = *positions;
    const std::vector<double>& nrm = *normals;
    for (std::size_t v = 0; v < count; ++v) {
        out.positions.push_back({pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]});
        out.normals.push_back(nrm.empty() ? Vec3d{}
                                          : Vec3d{nrm[3 * v], nrm[3 * v + 1], nrm[3 * v + 2]});
    }
    const std::size_t first = out.triangles.size();
    append_triangles(prim.mode, *indices, base, material, out);
    const UvMapping* mapping = material < uv_maps.size() ? &uv_maps[material] : nullptr;
    return add_corner_uvs(m, prim, where, mapping, base, count, first, out, warnings);
}

Result<LocalMesh> build_local_mesh(const tinygltf::Model& m, std::size_t mesh,
                                   const std::vector<double>& weights,
                                   const std::vector<UvMapping>& uv_maps,
                                   std::vector<std::string>& warnings) {
    LocalMesh out;
    bool normals_complete = true;
    for (std::size_t p = 0; p < m.meshes[mesh].primitives.size(); ++p) {
        if (Status st =
                add_primitive(m, mesh, p, weights, uv_maps, out, normals_complete, warnings);
            !st.ok())
            return st;
    }
    if (!out.any_uvs)
        out.corner_uvs.clear();
    if (!normals_complete) {
        if (std::any_of(out.normals.begin(), out.normals.end(),
                        [](const Vec3d& n) { return n != Vec3d{}; })) {
            warnings.push_back("/meshes/" + std::to_string(mesh) +
                               ": some primitives lack NORMAL; the mesh's normals are dropped");
        }
        out.normals.clear();
    }
    return out;
}

/// Places a local mesh in the world. A mirroring transform (negative determinant) reverses
/// each triangle so front faces stay counter-clockwise (glTF 2.0 §3.7.2.1).
ModelPart instance(const LocalMesh& local, const Transform& world, std::string name,
                   const std::function<std::uint32_t()>& default_material) {
    ModelPart part;
    part.name = std::move(name);
    TriangleMesh& mesh = part.mesh;
    mesh.positions.reserve(local.positions.size());
    for (const Vec3d& p : local.positions)
        mesh.positions.push_back(world.apply_point(p));
    mesh.normals.reserve(local.normals.size());
    for (const Vec3d& n : local.normals)
        mesh.normals.push_back(Vec3f(world.apply_normal(n)));
    const bool mirrored = world.determinant3() < 0.0;
    mesh.triangles = local.triangles;
    mesh.corner_uvs = local.corner_uvs;
    if (mirrored) {
        for (auto& t : mesh.triangles)
            std::swap(t[1], t[2]);
        for (auto& c : mesh.corner_uvs)
            std::swap(c[1], c[2]);
    }
    if (local.any_material) {
        mesh.triangle_material.reserve(local.materials.size());
        for (std::uint32_t id : local.materials) {
            mesh.triangle_material.push_back(id == kNoMaterial ? default_material() : id);
        }
    }
    return part;
}

std::string part_name(const tinygltf::Model& m, const tinygltf::Node& node,
                      std::string_view model_name, std::size_t part_index) {
    if (!node.name.empty())
        return node.name;
    const std::string& mesh_name = m.meshes[static_cast<std::size_t>(node.mesh)].name;
    if (!mesh_name.empty())
        return mesh_name;
    return std::string(model_name) + " mesh " + std::to_string(part_index + 1);
}

Status add_camera_and_lights(const tinygltf::Model& m, const std::vector<Placed>& placed,
                             LoadedModel& out) {
    bool skipped_camera = false;
    for (const Placed& p : placed) {
        const tinygltf::Node& node = m.nodes[static_cast<std::size_t>(p.node)];
        if (node.camera != -1 && !out.camera) {
            out.camera = to_camera(m.cameras[static_cast<std::size_t>(node.camera)], p.world);
            skipped_camera = skipped_camera || !out.camera;
        }
        auto light = node_light(node, p.node, m.lights.size());
        if (!light)
            return light.status();
        if (*light >= 0) {
            if (auto l =
                    to_light(m.lights[static_cast<std::size_t>(*light)], p.world, out.warnings))
                out.lights.push_back(*l);
        }
    }
    if (skipped_camera && !out.camera)
        out.warnings.push_back("no perspective camera (orthographic cameras are not supported)");
    normalize_light_intensities(out.lights);
    return {};
}

/// Builds each mesh once (at its default weights; again for nodes with their own weights) and
/// places one part per mesh node, in traversal order. `built` records which meshes were read.
Status instance_meshes(const tinygltf::Model& m, const std::vector<Placed>& placed,
                       std::string_view name, const LoadLimits& limits,
                       const std::vector<UvMapping>& uv_maps, std::vector<bool>& built,
                       LoadedModel& out) {
    std::optional<std::uint32_t> default_index;
    auto default_material = [&]() {
        if (!default_index) {
            default_index = static_cast<std::uint32_t>(out.materials.size());
            out.materials.push_back(Material{});
            out.material_names.push_back("default");
        }
        return *default_index;
    };
    std::map<std::size_t, LocalMesh> cache;
    std::size_t triangles = 0, vertices = 0;
    for (const Placed& p : placed) {
        const tinygltf::Node& node = m.nodes[static_cast<std::size_t>(p.node)];
        if (node.mesh == -1)
            continue;
        const auto mesh = static_cast<std::size_t>(node.mesh);
        built[mesh] = true;
        LocalMesh own;
        const LocalMesh* local = nullptr;
        if (!node.weights.empty()) {
            auto local_mesh = build_local_mesh(m, mesh, node.weights, uv_maps, out.warnings);
            if (!local_mesh)
                return local_mesh.status();
            own = std::move(*local_mesh);
            local = &own;
        } else if (auto it = cache.find(mesh); it != cache.end()) {
            local = &it->second;
        } else {
            auto local_mesh =
                build_local_mesh(m, mesh, m.meshes[mesh].weights, uv_maps, out.warnings);
            if (!local_mesh)
                return local_mesh.status();
            local = &cache.emplace(mesh, std::move(*local_mesh)).first->second;
        }
        triangles += local->triangles.size();
        vertices += local->positions.size();
        if (triangles > limits.max_triangles || vertices > limits.max_vertices) {
            return Status::error(Code::too_large,
                                 "more than " + std::to_string(limits.max_triangles) +
                                     " triangles or " + std::to_string(limits.max_vertices) +
                                     " vertices after instancing");
        }
        // A skinned mesh's node transform is ignored (glTF 2.0 §3.7.3); without applying the
        // skin, the mesh stays in its bind pose.
        Transform world = p.world;
        if (node.skin != -1) {
            world = Transform();
            out.warnings.push_back(node_path(static_cast<std::size_t>(p.node)) +
                                   ": skinning is not applied; the mesh is drawn in its bind pose");
        }
        out.parts.push_back(
            instance(*local, world, part_name(m, node, name, out.parts.size()), default_material));
    }
    return {};
}

}  // namespace

Status build_model(const tinygltf::Model& m, std::string_view name, const ResourceReader& read,
                   const LoadLimits& limits, LoadedModel& out) {
    if (Status st = check_hierarchy(m); !st.ok())
        return st;
    auto roots = scene_roots(m);
    if (!roots)
        return roots.status();
    auto placed = place_nodes(m, *roots);
    if (!placed)
        return placed.status();

    for (std::size_t i = 0; i < m.materials.size(); ++i) {
        out.materials.push_back(to_phong(m.materials[i]));
        out.material_names.push_back(m.materials[i].name.empty() ? "material " + std::to_string(i)
                                                                 : m.materials[i].name);
    }
    const std::vector<UvMapping> uv_maps =
        attach_base_color_textures(m, read, limits, out.materials, out.warnings);
    std::vector<bool> built(m.meshes.size(), false);
    if (Status st = instance_meshes(m, *placed, name, limits, uv_maps, built, out); !st.ok())
        return st;
    // Meshes no node instances are still checked (references, accessor types, index ranges),
    // so a file is accepted or refused as a whole, as the glTF-Validator judges it; their
    // warnings are not ours to report.
    for (std::size_t mesh = 0; mesh < m.meshes.size(); ++mesh) {
        if (built[mesh])
            continue;
        std::vector<std::string> unused_warnings;
        auto checked = build_local_mesh(m, mesh, m.meshes[mesh].weights, uv_maps, unused_warnings);
        if (!checked)
            return checked.status();
    }
    return add_camera_and_lights(m, *placed, out);
}

}  // namespace raycastd::engine::gltf
