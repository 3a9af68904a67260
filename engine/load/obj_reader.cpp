// Wavefront OBJ with MTL material libraries (Wavefront Technologies, "Object Files (.obj)" and
// "Material Library Files (.mtl)", Advanced Visualizer manual, appendix B1/B3).
//
// Read by hand rather than through OpenMesh's OBJ reader, because that reader opens `mtllib`
// files itself with std::fstream (relative to a path kept from the previous call), which would
// bypass the ResourceReader and so the scene-root confinement; keeps its state in a
// process-wide singleton, so concurrent loads would race; and reports materials only as face
// colours, losing the face → material mapping. OBJ is a line format with a handful of
// statements we need: v, vt, vn, f (and fo), usemtl, mtllib; everything else is skipped.

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include "engine/load/loaders.h"
#include "engine/load/text_scan.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine::detail {

namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

std::string trim(std::string_view s) {
    std::size_t b = 0, e = s.size();
    while (b < e && (is_blank(s[b])))
        ++b;
    while (e > b && (is_blank(s[e - 1])))
        --e;
    return std::string(s.substr(b, e - b));
}

/// The text after the keyword, trimmed (names may contain spaces).
std::string rest_of_line(std::string_view line, std::string_view keyword) {
    std::string_view s = line.substr(line.find(keyword) + keyword.size());
    return trim(s.substr(0, s.find('#')));
}

/// Reads 1 or 3 numbers after a colour keyword ("Kd 0.5" means grey); nullopt if malformed or
/// not finite (the material then keeps its default).
std::optional<Vec3d> parse_color(const std::vector<std::string_view>& t) {
    if (t.size() < 2)
        return std::nullopt;
    auto r = parse_double(t[1]);
    if (!r)
        return std::nullopt;
    if (t.size() < 4)
        return std::isfinite(*r) ? std::optional<Vec3d>(Vec3d{*r, *r, *r}) : std::nullopt;
    auto g = parse_double(t[2]), b = parse_double(t[3]);
    if (!g || !b)
        return std::nullopt;
    const Vec3d c{*r, *g, *b};
    return is_finite(c) ? std::optional<Vec3d>(c) : std::nullopt;
}

/// A material's `map_Kd`: the image's URI (relative to the model, backslashes turned into '/') and
/// the options that change where it is sampled (MTL appendix B3: -o origin offset, -s scale,
/// -clamp on).
struct DiffuseMap {
    std::string uri;
    std::array<double, 2> offset{0, 0};
    std::array<double, 2> scale{1, 1};
    bool clamp = false;
};

/// One `newmtl` entry: its Phong material and its diffuse map, if any.
struct MtlEntry {
    Material material;
    std::optional<DiffuseMap> map_kd;
};

/// `map_Kd [options] file`: the options MTL defines take a fixed number of arguments, except
/// -o, -s and -t, which take one to three numbers; what follows them is the file name, which
/// may contain spaces. `dir` is the MTL file's own directory, which names are relative to.
std::optional<DiffuseMap> parse_map(const std::vector<std::string_view>& t,
                                    const std::string& dir) {
    static const std::map<std::string_view, int> kArity = {
        {"-blendu", 1}, {"-blendv", 1}, {"-boost", 1},   {"-mm", 2}, {"-texres", 1},
        {"-clamp", 1},  {"-bm", 1},     {"-imfchan", 1}, {"-cc", 1}, {"-type", 1}};
    DiffuseMap map;
    std::size_t i = 1;
    while (i < t.size() && t[i].size() > 1 && t[i][0] == '-') {
        const std::string_view opt = t[i++];
        if (opt == "-o" || opt == "-s" || opt == "-t") {
            std::array<double, 3> v{opt == "-s" ? 1.0 : 0.0, opt == "-s" ? 1.0 : 0.0, 0.0};
            for (std::size_t k = 0; k < 3 && i < t.size(); ++k, ++i) {
                auto x = parse_double(t[i]);
                if (!x || !std::isfinite(*x))
                    break;
                v[k] = *x;
            }
            if (opt == "-o")
                map.offset = {v[0], v[1]};
            if (opt == "-s")
                map.scale = {v[0], v[1]};
            continue;
        }
        auto a = kArity.find(opt);
        if (a == kArity.end()) {
            --i;  // not an option after all: the file name starts with it
            break;
        }
        if (opt == "-clamp" && i < t.size())
            map.clamp = t[i] == "on";
        i += static_cast<std::size_t>(a->second);
    }
    std::string name;
    for (; i < t.size(); ++i)
        name += (name.empty() ? "" : " ") + std::string(t[i]);
    if (name.empty())
        return std::nullopt;
    std::replace(name.begin(), name.end(), '\\', '/');
    while (name.rfind("./", 0) == 0)
        name.erase(0, 2);
    map.uri = dir + name;
    return map;
}

/// MTL statements mapped to Phong: Kd → diffuse, Ka → ambient (0.1·Kd when absent, as for
/// glTF), Ks → specular, Ns → shininess (clamped to the MTL range 0..1000), d → 1 −
/// transparency, Ni → index of refraction, Ke → emissive; map_Kd → the diffuse map, whose
/// colour multiplies diffuse and ambient (the other maps are not sampled).
void parse_mtl(std::string_view text, const std::string& dir,
               std::map<std::string, MtlEntry>& out) {
    LineReader lines(text);
    std::string_view line;
    Material* current = nullptr;
    MtlEntry* entry = nullptr;
    bool has_ambient = false;
    auto close = [&]() {
        if (current && !has_ambient)
            current->ambient = current->diffuse * 0.1;
    };
    while (lines.next(line)) {
        auto t = tokens(line);
        if (t.empty())
            continue;
        if (t[0] == "newmtl") {
            close();
            entry = &out[rest_of_line(line, "newmtl")];
            *entry = MtlEntry{};
            current = &entry->material;
            has_ambient = false;
            continue;
        }
        if (!current)
            continue;
        auto number = t.size() >= 2 ? parse_double(t[1]) : std::nullopt;
        if (t[0] == "Kd") {
            if (auto c = parse_color(t))
                current->diffuse = *c;
        } else if (t[0] == "Ka") {
            if (auto c = parse_color(t))
                current->ambient = *c, has_ambient = true;
        } else if (t[0] == "Ks") {
            if (auto c = parse_color(t))
                current->specular = *c;
        } else if (t[0] == "Ke") {
            if (auto c = parse_color(t))
                current->emissive = *c;
        } else if (t[0] == "Ns" && number && std::isfinite(*number)) {
            current->shininess = std::clamp(*number, 0.0, 1000.0);
        } else if (t[0] == "d" && number && *number >= 0.0 && *number <= 1.0) {
            current->transparency = 1.0 - *number;
        } else if (t[0] == "Ni" && number && *number > 0.0 && std::isfinite(*number)) {
            current->ior = *number;
        } else if (t[0] == "map_Kd") {
            entry->map_kd = parse_map(tokens(line, /*comments=*/false), dir);
        }
    }
    close();
}

class ObjReader {
  public:
    ObjReader(const ResourceReader& read, std::string_view name, const LoadLimits& limits)
        : read_(read), name_(name), limits_(limits) {
        part_.name = std::string(name);
    }

    Result<LoadedModel> run(std::string_view text) {
        LineReader lines(text);
        std::string_view raw;
        std::string joined;
        while (lines.next(raw)) {
            std::string_view line = raw;
            // A backslash at the end of a line continues the statement on the next line.
            if (!raw.empty() && raw.back() == '\\') {
                joined.assign(raw.substr(0, raw.size() - 1));
                std::string_view more;
                while (lines.next(more)) {
                    const bool continues = !more.empty() && more.back() == '\\';
                    joined.push_back(' ');
                    joined.append(more.substr(0, more.size() - (continues ? 1 : 0)));
                    if (!continues)
                        break;
                }
                line = joined;
            }
            if (Status st = statement(line, lines.number()); !st.ok())
                return st;
        }
        return finish();
    }

  private:
    Status error(std::size_t line, const std::string& what) {
        return load_error(name_, "line " + std::to_string(line) + ": " + what);
    }

    Status statement(std::string_view line, std::size_t n) {
        auto t = tokens(line);
        if (t.empty())
            return {};
        const std::string_view k = t[0];
        if (k == "v") {
            if (t.size() < 4)
                return error(n, "a vertex needs x, y and z");
            auto x = parse_double(t[1]), y = parse_double(t[2]), z = parse_double(t[3]);
            if (!x || !y || !z)
                return error(n, "malformed vertex coordinate");
            part_.mesh.positions.push_back({*x, *y, *z});
            vertex_normal_.push_back(kNone);
        } else if (k == "vt") {
            // vt u [v [w]]: v and w default to 0 (appendix B1).
            auto u = t.size() >= 2 ? parse_double(t[1]) : std::nullopt;
            auto v = t.size() >= 3 ? parse_double(t[2]) : std::optional<double>(0.0);
            if (!u || !v)
                return error(n, "malformed texture coordinate");
            texcoords_.push_back({*u, *v});
        } else if (k == "vn") {
            if (t.size() < 4)
                return error(n, "a normal needs x, y and z");
            auto x = parse_double(t[1]), y = parse_double(t[2]), z = parse_double(t[3]);
            if (!x || !y || !z)
                return error(n, "malformed normal");
            normals_.push_back({*x, *y, *z});
        } else if (k == "f" || k == "fo") {
            return face(t, n);
        } else if (k == "l" || k == "p") {
            ++skipped_lines_points_;
        } else if (k == "usemtl") {
            material_ = material_index(rest_of_line(line, "usemtl"));
        } else if (k == "mtllib") {
            load_library(line, t);
        }
        return {};
    }

    /// Resolves a 1-based OBJ index, or a negative one counting back from the last element
    /// defined so far ("-1" is the latest); 0 and out-of-range indices are errors.
    std::optional<std::uint32_t> resolve(std::string_view s, std::size_t defined) {
        auto v = parse_int(s);
        if (!v || *v == 0)
            return std::nullopt;
        std::int64_t i = *v > 0 ? *v - 1 : static_cast<std::int64_t>(defined) + *v;
        if (i < 0 || i >= static_cast<std::int64_t>(defined))
            return std::nullopt;
        return static_cast<std::uint32_t>(i);
    }

    /// A face corner's vt or vn index, kNone when it is out of range: a bad index costs that
    /// attribute (shading only), not the geometry; the first of each kind is a warning, and
    /// `bad` records it.
    std::uint32_t attribute_index(std::string_view s, std::size_t defined, bool& bad,
                                  std::size_t line, std::string_view corner, const char* kind,
                                  const char* dropped) {
        if (auto i = resolve(s, defined))
            return *i;
        if (!bad) {
            bad = true;
            model_.warnings.push_back("line " + std::to_string(line) + ": " + kind + " index in '" +
                                      std::string(corner) + "' is out of range; " + dropped +
                                      " dropped");
        }
        return kNone;
    }

    Status face(const std::vector<std::string_view>& t, std::size_t n) {
        poly_.clear();
        poly_uv_.clear();
        for (std::size_t i = 1; i < t.size(); ++i) {
            std::string_view corner = t[i];
            const std::size_t slash = corner.find('/');
            auto v = resolve(corner.substr(0, slash), part_.mesh.positions.size());
            if (!v) {
                return error(n, "face vertex '" + std::string(corner) + "' is not one of the " +
                                    std::to_string(part_.mesh.positions.size()) +
                                    " vertices defined so far");
            }
            poly_.push_back(*v);
            // v/vt/vn or v//vn: remember the normal; a vertex must keep one normal throughout.
            std::uint32_t normal = kNone;
            std::uint32_t uv = kNone;
            if (slash != std::string_view::npos) {
                std::string_view rest = corner.substr(slash + 1);
                const std::size_t slash2 = rest.find('/');
                if (const std::string_view vt = rest.substr(0, slash2); !vt.empty()) {
                    uv = attribute_index(vt, texcoords_.size(), bad_uv_index_, n, corner, "texture",
                                         "texture coordinates");
                }
                if (slash2 != std::string_view::npos && slash2 + 1 < rest.size()) {
                    normal = attribute_index(rest.substr(slash2 + 1), normals_.size(),
                                             bad_normal_index_, n, corner, "normal", "normals");
                }
            }
            poly_uv_.push_back(uv);
            std::uint32_t& assigned = vertex_normal_[*v];
            if (normal == kNone || (assigned != kNone && assigned != normal)) {
                normals_consistent_ = false;
            } else {
                assigned = normal;
            }
        }
        const std::size_t added = add_fan(part_.mesh, poly_);
        if (added == 0) {
            ++short_faces_;
            return {};
        }
        triangle_material_.insert(triangle_material_.end(), added, material_);
        add_corner_uvs(added);
        if (part_.mesh.triangles.size() > limits_.max_triangles) {
            return Status::error(Code::too_large, std::string(name_) + ": more than " +
                                                      std::to_string(limits_.max_triangles) +
                                                      " triangles");
        }
        return {};
    }

    /// The corners of the `added` fan triangles (v0, vi, vi+1) just appended, in glTF's uv
    /// convention (v ↦ 1 − v, engine/scene/texture.h) after the material's -s and -o; (0, 0)
    /// for a corner without vt.
    void add_corner_uvs(std::size_t added) {
        const DiffuseMap* map =
            material_ < maps_.size() && maps_[material_] ? &*maps_[material_] : nullptr;
        auto corner = [&](std::size_t k) -> std::array<float, 2> {
            const std::uint32_t i = poly_uv_[k];
            if (i == kNone)
                return {0.0f, 0.0f};
            any_uv_ = true;
            double u = texcoords_[i][0], v = texcoords_[i][1];
            if (map) {
                u = map->scale[0] * u + map->offset[0];
                v = map->scale[1] * v + map->offset[1];
            }
            return {to_float(u), to_float(1.0 - v)};  // vt may lie past float's range
        };
        for (std::size_t i = 1; i <= added; ++i)
            corner_uvs_.push_back({corner(0), corner(i), corner(i + 1)});
    }

    /// The texture of a diffuse map, decoded once per image file; null (with a warning) when
    /// it cannot be read or decoded.
    std::shared_ptr<const Texture> texture_of(const DiffuseMap& map) {
        if (!limits_.textures)
            return nullptr;  // not asked for: neither read nor decoded
        auto cached = textures_.find(map.uri);
        if (cached == textures_.end()) {
            Status allowed = check_resource_uri(map.uri);
            auto bytes = allowed.ok() ? read_(map.uri) : Result<std::string>(allowed);
            auto image = bytes ? decode_texture_image(*bytes, limits_, decoded_pixels_)
                               : Result<std::shared_ptr<const TextureImage>>(bytes.status());
            if (!image) {
                model_.warnings.push_back("map_Kd '" + map.uri + "': " + image.status().message +
                                          "; the material's Kd is used alone");
            }
            cached = textures_.emplace(map.uri, image ? *image : nullptr).first;
        }
        if (!cached->second)
            return nullptr;
        auto texture = std::make_shared<Texture>();
        texture->image = cached->second;
        if (map.clamp)
            texture->wrap_s = texture->wrap_t = TextureWrap::clamp_to_edge;
        return texture;
    }

    std::uint32_t material_index(const std::string& mtl) {
        if (auto it = used_.find(mtl); it != used_.end())
            return it->second;
        auto lib = library_.find(mtl);
        if (lib == library_.end()) {
            model_.warnings.push_back(
                "material '" + mtl +
                "' is not defined in any loaded mtllib; default material used");
        }
        const auto index = static_cast<std::uint32_t>(model_.materials.size());
        model_.materials.push_back(lib == library_.end() ? Material{} : lib->second.material);
        maps_.push_back(lib == library_.end() ? std::nullopt : lib->second.map_kd);
        if (maps_.back()) {
            model_.materials.back().texture = texture_of(*maps_.back());
            if (!model_.materials.back().texture)
                maps_.back().reset();
        }
        model_.material_names.push_back(mtl);
        used_.emplace(mtl, index);
        return index;
    }

    /// `mtllib a.mtl b.mtl` names one or more files; a single name may contain spaces, so the
    /// whole argument is tried first. Windows separators are turned into '/'.
    void load_library(std::string_view line, const std::vector<std::string_view>& t) {
        std::vector<std::string> names{rest_of_line(line, "mtllib")};
        if (t.size() > 2) {
            for (std::size_t i = 1; i < t.size(); ++i)
                names.emplace_back(t[i]);
        }
        bool any = false;
        for (std::size_t i = 0; i < names.size() && !(any && i == 1); ++i) {
            std::string uri = names[i];
            std::replace(uri.begin(), uri.end(), '\\', '/');
            if (uri.rfind("./", 0) == 0)
                uri.erase(0, 2);
            Status allowed = check_resource_uri(uri);
            auto bytes = allowed.ok() ? read_(uri) : Result<std::string>(allowed);
            if (bytes) {
                const std::size_t slash = uri.rfind('/');
                parse_mtl(*bytes, slash == std::string::npos ? "" : uri.substr(0, slash + 1),
                          library_);
                any = true;
            }
        }
        if (!any)
            model_.warnings.push_back("material library '" + names.front() +
                                      "' could not be read; default materials used");
    }

    Result<LoadedModel> finish() {
        TriangleMesh& mesh = part_.mesh;
        if (normals_consistent_ && !normals_.empty() && !mesh.triangles.empty()) {
            mesh.normals.resize(mesh.positions.size());
            for (std::size_t v = 0; v < vertex_normal_.size(); ++v) {
                if (vertex_normal_[v] != kNone)
                    mesh.normals[v] = Vec3f(normals_[vertex_normal_[v]]);
            }
        }
        if (std::any_of(triangle_material_.begin(), triangle_material_.end(),
                        [](std::uint32_t m) { return m != kNone; })) {
            std::uint32_t fallback = kNone;
            for (std::uint32_t& m : triangle_material_) {
                if (m != kNone)
                    continue;
                if (fallback == kNone) {
                    fallback = static_cast<std::uint32_t>(model_.materials.size());
                    model_.materials.push_back(Material{});
                    model_.material_names.push_back("default");
                }
                m = fallback;
            }
            mesh.triangle_material = std::move(triangle_material_);
        }
        // Texture coordinates are kept only where they are used: some face has them and some
        // material that a face uses is textured.
        if (any_uv_ && !bad_uv_index_ &&
            std::any_of(maps_.begin(), maps_.end(), [](const auto& m) { return m; }) &&
            corner_uvs_.size() == mesh.triangles.size()) {
            mesh.corner_uvs = std::move(corner_uvs_);
        }
        if (short_faces_ > 0)
            model_.warnings.push_back(std::to_string(short_faces_) +
                                      " faces with fewer than 3 vertices skipped");
        if (skipped_lines_points_ > 0)
            model_.warnings.push_back(std::to_string(skipped_lines_points_) +
                                      " line/point statements skipped (only faces are ray-traced)");
        model_.parts.push_back(std::move(part_));
        if (Status st = finish_model(model_, name_, limits_); !st.ok())
            return st;
        return std::move(model_);
    }

    const ResourceReader& read_;
    std::string_view name_;
    const LoadLimits& limits_;
    LoadedModel model_;
    ModelPart part_;
    std::vector<Vec3d> normals_;
    std::vector<std::uint32_t> vertex_normal_;  ///< per vertex: its vn index, kNone if unseen
    bool normals_consistent_ = true;
    bool bad_normal_index_ = false;
    std::vector<std::uint32_t> triangle_material_;
    std::vector<std::uint32_t> poly_;
    std::vector<std::array<double, 2>> texcoords_;  ///< vt, as the file writes them
    std::vector<std::uint32_t> poly_uv_;  ///< the current face's vt indices, kNone for none
    std::vector<std::array<std::array<float, 2>, 3>> corner_uvs_;  ///< per triangle
    bool any_uv_ = false;
    bool bad_uv_index_ = false;
    std::map<std::string, MtlEntry> library_;      ///< every material of every mtllib read
    std::vector<std::optional<DiffuseMap>> maps_;  ///< per model material: its usable map_Kd
    std::map<std::string, std::shared_ptr<const TextureImage>> textures_;  ///< by image URI
    std::size_t decoded_pixels_ = 0;  ///< of the textures decoded so far
    std::map<std::string, std::uint32_t> used_;
    std::uint32_t material_ = kNone;
    std::size_t short_faces_ = 0;
    std::size_t skipped_lines_points_ = 0;
};

}  // namespace

Result<LoadedModel> load_obj(std::string_view bytes, const ResourceReader& read,
                             std::string_view name, const LoadLimits& limits) {
    return ObjReader(read, name, limits).run(bytes);
}

}  // namespace raycastd::engine::detail
