// glTF scene graph → world-space parts: node hierarchy checks and traversal, primitive
// assembly (indices, strips, fans, morph targets at their default weights), instancing.

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include "engine/load/gltf_internal.h"
#include "engine/math/float_bounds.h"

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
    /// Skin influences, kInfluences per vertex (JOINTS_0/WEIGHTS_0, then JOINTS_1/WEIGHTS_1),
    /// weight 0 in unused slots; empty when no primitive has JOINTS_0.
    /// (glTF allows only unsigned byte and short joint indices, §3.7.3.2.)
    std::vector<std::uint16_t> joints;
    std::vector<float> weights;
};

/// Influences kept per vertex: two JOINTS_n/WEIGHTS_n sets of four (glTF 2.0 §3.7.3.3 allows
/// more; a third set is rare enough to be reported and ignored).
constexpr std::size_t kInfluences = 8;

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
        if (node.skin != -1 && !in_range(node.skin, m.skins.size())) {
            return fail(node_path(i) + "/skin refers to skin " + std::to_string(node.skin) +
                        ", but the file has " + std::to_string(m.skins.size()));
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

/// The nodes that are no node's child, in file order.
std::vector<int> root_nodes(const tinygltf::Model& m) {
    std::vector<bool> is_child(m.nodes.size(), false);
    for (const auto& node : m.nodes) {
        for (int c : node.children)
            is_child[static_cast<std::size_t>(c)] = true;
    }
    std::vector<int> roots;
    for (std::size_t i = 0; i < m.nodes.size(); ++i) {
        if (!is_child[i])
            roots.push_back(static_cast<int>(i));
    }
    return roots;
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
    return root_nodes(m);
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
                // to_float: a transform's scale can take a coordinate past float's range.
                corners[c] = {to_float(k[0] * u0 + k[1] * v0 + k[2]),
                              to_float(k[3] * u0 + k[4] * v0 + k[5])};
            }
        }
        out.corner_uvs.push_back(corners);
    }
    return {};
}

/// Appends the primitive's skin influences (count vertices) to out.joints and out.weights:
/// JOINTS_n as unsigned integers and WEIGHTS_n as floats or normalized integers (§3.7.3.3),
/// for n = 0, 1. Vertices of a primitive without JOINTS_0 get no influence. Nothing is kept
/// until some primitive of the mesh has JOINTS_0.
Status add_influences(const tinygltf::Model& m, const tinygltf::Primitive& prim,
                      const std::string& where, std::size_t count, LocalMesh& out,
                      std::vector<std::string>& warnings) {
    const bool skinned = prim.attributes.count("JOINTS_0") && prim.attributes.count("WEIGHTS_0");
    if (!skinned && out.joints.empty())
        return {};
    const std::size_t before = out.positions.size() - count;  // this primitive's first vertex
    // Earlier primitives without a skin, and this one until it is read, get no influence.
    out.joints.resize(out.positions.size() * kInfluences, 0);
    out.weights.resize(out.positions.size() * kInfluences, 0.0);
    if (!skinned)
        return {};
    if (prim.attributes.count("JOINTS_2"))
        warnings.push_back(where + ": more than 8 joint influences per vertex; the rest ignored");
    for (std::size_t set = 0; set < kInfluences / 4; ++set) {
        const std::string js = "JOINTS_" + std::to_string(set),
                          ws = "WEIGHTS_" + std::to_string(set);
        auto j_it = prim.attributes.find(js), w_it = prim.attributes.find(ws);
        if (j_it == prim.attributes.end() || w_it == prim.attributes.end())
            break;
        auto joints = read_floats(m, j_it->second, 4, where + "/attributes/" + js);
        if (!joints)
            return joints.status();
        auto weights = read_floats(m, w_it->second, 4, where + "/attributes/" + ws);
        if (!weights)
            return weights.status();
        if (joints->size() != 4 * count || weights->size() != 4 * count) {
            return fail(where + ": " + js + " or " + ws + " count differs from POSITION count");
        }
        for (std::size_t v = 0; v < count; ++v) {
            for (std::size_t k = 0; k < 4; ++k) {
                const double j = (*joints)[4 * v + k], w = (*weights)[4 * v + k];
                const std::size_t slot = (before + v) * kInfluences + 4 * set + k;
                if (!(j >= 0.0) || j > std::numeric_limits<std::uint16_t>::max())
                    return fail(where + "/attributes/" + js + " has an invalid joint index");
                out.joints[slot] = static_cast<std::uint16_t>(j);
                // Weights are floats or normalized integers in [0, 1] (§3.7.3.2).
                out.weights[slot] = std::isfinite(w) && w > 0.0 ? static_cast<float>(w) : 0.0f;
            }
        }
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
    if (Status st = add_influences(m, prim, where, count, out, warnings); !st.ok())
        return st;
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
using JointMatrix = std::array<std::array<double, 4>, 4>;

/// Vertex v's skinning transform: Σₖ wₖ · joints[jₖ] over its influences, with the weights
/// divided by their sum (quantized weights rarely sum to exactly 1); the identity, its bind
/// pose, for a vertex without weight. skin_transforms() has checked every joint index.
Transform blend(const LocalMesh& local, const std::vector<JointMatrix>& joints, std::size_t v) {
    JointMatrix sum{};
    double total = 0.0;
    for (std::size_t k = 0; k < kInfluences; ++k) {
        const double w = local.weights[v * kInfluences + k];
        if (w == 0.0)
            continue;
        const JointMatrix& j = joints[local.joints[v * kInfluences + k]];
        for (std::size_t r = 0; r < 4; ++r) {
            for (std::size_t c = 0; c < 4; ++c)
                sum[r][c] += w * j[r][c];
        }
        total += w;
    }
    if (!(total > 0.0))
        return Transform();
    for (auto& row : sum) {
        for (double& e : row)
            e /= total;
    }
    return Transform(sum);
}

/// `skin` (when not null) holds the joint matrices of a skinned mesh (skin_transforms()):
/// each vertex then moves by its own blend of them, computed as it is placed, and the
/// mirroring test is made per triangle, on its first vertex's transform.
ModelPart instance(const LocalMesh& local, const Transform& world,
                   const std::vector<JointMatrix>* skin, std::string name,
                   const std::function<std::uint32_t()>& default_material) {
    ModelPart part;
    part.name = std::move(name);
    TriangleMesh& mesh = part.mesh;
    const bool skinned = skin && local.joints.size() == local.positions.size() * kInfluences;
    std::vector<char> mirrors(skinned ? local.positions.size() : 0);
    mesh.positions.reserve(local.positions.size());
    mesh.normals.reserve(local.normals.size());
    for (std::size_t v = 0; v < local.positions.size(); ++v) {
        const Transform t = skinned ? blend(local, *skin, v) : skin ? Transform() : world;
        mesh.positions.push_back(t.apply_point(local.positions[v]));
        if (!local.normals.empty())
            mesh.normals.push_back(Vec3f(t.apply_normal(local.normals[v])));
        if (skinned)
            mirrors[v] = t.determinant3() < 0.0;
    }
    mesh.triangles = local.triangles;
    mesh.corner_uvs = local.corner_uvs;
    const bool world_mirrors = !skin && world.determinant3() < 0.0;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        auto& tri = mesh.triangles[t];
        if (!(skinned ? mirrors[tri[0]] != 0 : world_mirrors))
            continue;
        std::swap(tri[1], tri[2]);
        if (!mesh.corner_uvs.empty())
            std::swap(mesh.corner_uvs[t][1], mesh.corner_uvs[t][2]);
    }
    if (local.any_material) {
        mesh.triangle_material.reserve(local.materials.size());
        for (std::uint32_t id : local.materials) {
            mesh.triangle_material.push_back(id == kNoMaterial ? default_material() : id);
        }
    }
    return part;
}

/// The joint matrices of a skin in the default pose (glTF 2.0 §3.7.3.3, linear blend
/// skinning): joint j's is globalTransform(joint j) · inverseBindMatrix j, and a vertex moves by
/// the blend of its joints' (blend()). The skinned node's own transform plays no part
/// (§3.7.3.1). `node_world` holds every node's global transform in the file's rest pose (no
/// animation is played). Every joint index `local` uses with a weight is checked here.
Result<std::vector<JointMatrix>> skin_transforms(const tinygltf::Model& m, int skin_index,
                                                 const std::vector<Transform>& node_world,
                                                 const LocalMesh& local) {
    const tinygltf::Skin& skin = m.skins[static_cast<std::size_t>(skin_index)];
    const std::string where = "/skins/" + std::to_string(skin_index);
    std::vector<double> ibm;
    if (skin.inverseBindMatrices != -1) {
        auto read = read_floats(m, skin.inverseBindMatrices, 16, where + "/inverseBindMatrices");
        if (!read)
            return read.status();
        if (read->size() < 16 * skin.joints.size())
            return fail(where + "/inverseBindMatrices has fewer matrices than the skin has joints");
        ibm = std::move(*read);
    }
    std::vector<JointMatrix> joints(skin.joints.size());
    for (std::size_t j = 0; j < skin.joints.size(); ++j) {
        if (!in_range(skin.joints[j], m.nodes.size())) {
            return fail(where + "/joints/" + std::to_string(j) + " is not a node of the file");
        }
        Transform inverse_bind;
        if (!ibm.empty()) {
            std::array<double, 16> cm{};
            std::copy(ibm.begin() + static_cast<std::ptrdiff_t>(16 * j),
                      ibm.begin() + static_cast<std::ptrdiff_t>(16 * j + 16), cm.begin());
            inverse_bind = Transform::from_column_major(cm);
        }
        const Transform joint = node_world[static_cast<std::size_t>(skin.joints[j])] * inverse_bind;
        if (!joint.is_finite())
            return fail(where + "/joints/" + std::to_string(j) + ": joint matrix overflows");
        joints[j] = joint.rows();
    }
    for (std::size_t k = 0; k < local.joints.size(); ++k) {
        if (local.weights[k] != 0.0f && local.joints[k] >= joints.size()) {
            return fail(where + ": a vertex names joint " + std::to_string(local.joints[k]) +
                        ", but the skin has " + std::to_string(joints.size()));
        }
    }
    return joints;
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
            if (out.camera && !has_view(*out.camera)) {
                // Placed where its one-unit look_at rounds onto its position (beyond ~1e16),
                // or by a matrix that makes its up parallel to its view: no view to render.
                out.warnings.push_back(node_path(static_cast<std::size_t>(p.node)) +
                                       ": its camera has no view (placed too far out, or a "
                                       "degenerate transform); the default camera is used");
                out.camera.reset();
            }
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
                       const std::vector<UvMapping>& uv_maps,
                       const std::vector<Transform>& node_world, std::vector<bool>& built,
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
        std::optional<std::vector<JointMatrix>> skin;
        if (node.skin != -1) {
            auto posed = skin_transforms(m, node.skin, node_world, *local);
            if (!posed)
                return posed.status();
            skin = std::move(*posed);
        }
        out.parts.push_back(instance(*local, p.world, skin ? &*skin : nullptr,
                                     part_name(m, node, name, out.parts.size()), default_material));
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
        const std::vector<double>& e = m.materials[i].emissiveFactor;
        if (m.materials[i].emissiveTexture.index >= 0 &&
            std::any_of(e.begin(), e.end(), [](double c) { return c > 0.0; })) {
            out.warnings.push_back("/materials/" + std::to_string(i) +
                                   ": its emissiveTexture is not read, so its emission is left "
                                   "out");
        }
        out.material_names.push_back(m.materials[i].name.empty() ? "material " + std::to_string(i)
                                                                 : m.materials[i].name);
    }
    // The model's images together count against the scene's texture budget: the base colours
    // first, which change how the model looks most (four 4096² metallic-roughness maps decoded
    // first had left none for them: a helper's review), then the metallic-roughness means, with
    // which each material is mapped again, keeping its base-colour texture.
    std::size_t decoded_pixels = 0;
    const std::vector<UvMapping> uv_maps =
        attach_base_color_textures(m, read, limits, out.materials, out.warnings, decoded_pixels);
    const auto metallic_roughness =
        metallic_roughness_means(m, read, limits, decoded_pixels, out.warnings);
    for (std::size_t i = 0; i < m.materials.size(); ++i) {
        if (!metallic_roughness[i])
            continue;
        Material mapped = to_phong(m.materials[i], metallic_roughness[i]);
        mapped.texture = out.materials[i].texture;
        out.materials[i] = std::move(mapped);
    }
    // Joints need the global transform of nodes that the scene may not place (a skeleton can
    // live outside the scene's roots), so every node's is computed from every root.
    std::vector<Transform> node_world(m.nodes.size());
    if (!m.skins.empty()) {
        auto everything = place_nodes(m, root_nodes(m));
        if (!everything)
            return everything.status();
        for (const Placed& p : *everything)
            node_world[static_cast<std::size_t>(p.node)] = p.world;
    }
    std::vector<bool> built(m.meshes.size(), false);
    if (Status st = instance_meshes(m, *placed, name, limits, uv_maps, node_world, built, out);
        !st.ok())
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
