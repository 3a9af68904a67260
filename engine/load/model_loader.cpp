// Format names and sniffing, the catch-all boundary around the loaders, and the checks every
// format shares.

#include "engine/load/model_loader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <new>

#include "engine/load/loaders.h"
#include "engine/utf8.h"

namespace raycastd::engine {

using detail::lower;

namespace {

bool starts_with(std::string_view s, std::string_view prefix) {
    return s.size() >= prefix.size() && s.compare(0, prefix.size(), prefix) == 0;
}

std::string_view skip_space(std::string_view s) {
    std::size_t i = 0;
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i])))
        ++i;
    // A UTF-8 byte-order mark is not content.
    if (s.substr(i, 3) == "\xEF\xBB\xBF")
        return skip_space(s.substr(i + 3));
    return s.substr(i);
}

/// 84 + 50·n == size, n read from bytes 80..83 (little-endian): the binary STL layout.
bool is_binary_stl_size(std::string_view b) {
    if (b.size() < 84)
        return false;
    std::uint32_t n = 0;
    for (int i = 3; i >= 0; --i)
        n = n << 8 | static_cast<unsigned char>(b[80 + static_cast<std::size_t>(i)]);
    return 84 + 50 * static_cast<std::uint64_t>(n) == b.size();
}

}  // namespace

std::optional<ModelFormat> format_from_name(std::string_view name_or_ext) {
    std::string s = lower(name_or_ext);
    if (auto dot = s.rfind('.'); dot != std::string::npos)
        s.erase(0, dot + 1);
    if (s == "gltf")
        return ModelFormat::gltf;
    if (s == "glb")
        return ModelFormat::glb;
    if (s == "obj")
        return ModelFormat::obj;
    if (s == "ply")
        return ModelFormat::ply;
    if (s == "stl")
        return ModelFormat::stl;
    if (s == "off")
        return ModelFormat::off;
    return std::nullopt;
}

std::string_view format_name(ModelFormat format) {
    switch (format) {
        case ModelFormat::gltf:
            return "gltf";
        case ModelFormat::glb:
            return "glb";
        case ModelFormat::obj:
            return "obj";
        case ModelFormat::ply:
            return "ply";
        case ModelFormat::stl:
            return "stl";
        case ModelFormat::off:
            return "off";
    }
    return "unknown";
}

std::optional<ModelFormat> sniff_format(std::string_view bytes) {
    if (starts_with(bytes, "glTF"))
        return ModelFormat::glb;
    // Binary STL has an arbitrary 80-byte header (it may even say "solid"), so its size rule
    // is checked before any text signature.
    if (is_binary_stl_size(bytes))
        return ModelFormat::stl;
    std::string_view text = skip_space(bytes);
    if (starts_with(text, "{"))
        return ModelFormat::gltf;
    if (starts_with(text, "ply\n") || starts_with(text, "ply\r"))
        return ModelFormat::ply;
    if (starts_with(lower(text.substr(0, 5)), "solid"))
        return ModelFormat::stl;
    // OFF headers: [ST][C][N][4][n]OFF, optionally followed by counts or BINARY.
    std::size_t i = 0;
    if (starts_with(text, "ST"))
        i = 2;
    for (char c : {'C', 'N', '4', 'n'}) {
        if (i < text.size() && text[i] == c)
            ++i;
    }
    if (text.substr(i, 3) == "OFF")
        return ModelFormat::off;
    return std::nullopt;
}

ResourceReader no_resources() {
    return [](const std::string& uri) -> Result<std::string> {
        return Status::error(Code::not_found,
                             "'" + uri + "': this model may not refer to other files");
    };
}

std::size_t LoadedModel::triangle_count() const {
    std::size_t n = 0;
    for (const ModelPart& p : parts)
        n += p.mesh.size();
    return n;
}

Result<LoadedModel> load_model(std::string_view bytes, ModelFormat format,
                               const ResourceReader& read_resource, std::string_view display_name,
                               const LoadLimits& limits) {
    // The one place where exceptions from parsers and allocation stop: nothing crosses the API.
    try {
        switch (format) {
            case ModelFormat::gltf:
                return detail::load_gltf(bytes, false, read_resource, display_name, limits);
            case ModelFormat::glb:
                return detail::load_gltf(bytes, true, read_resource, display_name, limits);
            case ModelFormat::obj:
                return detail::load_obj(bytes, read_resource, display_name, limits);
            case ModelFormat::ply:
                return detail::load_ply(bytes, display_name, limits);
            case ModelFormat::stl:
                return detail::load_stl(bytes, display_name, limits);
            case ModelFormat::off:
                return detail::load_off(bytes, display_name, limits);
        }
        return Status::error(Code::unsupported_format,
                             std::string(display_name) + ": unknown format");
    } catch (const std::bad_alloc&) {
        return Status::error(Code::too_large,
                             std::string(display_name) + ": out of memory while loading");
    } catch (const std::exception& e) {
        return detail::load_error(display_name, std::string("parser error: ") + e.what());
    } catch (...) {
        return Status::error(Code::internal,
                             std::string(display_name) + ": unknown exception while loading");
    }
}

void apply_transform(LoadedModel& model, const Transform& t) {
    const bool mirrored = t.determinant3() < 0.0;
    for (ModelPart& part : model.parts) {
        for (Vec3d& p : part.mesh.positions)
            p = t.apply_point(p);
        for (Vec3f& n : part.mesh.normals)
            n = Vec3f(t.apply_normal(Vec3d(n)));
        if (mirrored) {
            for (auto& tri : part.mesh.triangles)
                std::swap(tri[1], tri[2]);
            for (auto& c : part.mesh.corner_uvs)
                std::swap(c[1], c[2]);
        }
    }
    for (Light& l : model.lights) {
        if (l.type == LightType::point)
            l.position = t.apply_point(l.position);
        if (l.type == LightType::directional)
            l.direction = normalize(t.apply_vector(l.direction));
    }
    if (model.camera) {
        Camera& c = *model.camera;
        c.position = t.apply_point(c.position);
        c.look_at = t.apply_point(c.look_at);
        c.up = normalize(t.apply_vector(c.up));
    }
}

namespace detail {

Status load_error(std::string_view name, const std::string& message) {
    return Status::error(Code::model_load_failed, std::string(name) + ": " + message);
}

Status with_name(std::string_view name, Status status) {
    status.message = std::string(name) + ": " + status.message;
    return status;
}

Status check_resource_uri(std::string_view uri) {
    auto refuse = [&](const char* why) {
        return Status::error(Code::invalid_scene,
                             "resource '" + std::string(uri) + "' refused: " + why);
    };
    if (uri.empty())
        return refuse("empty URI");
    if (uri[0] == '/' || uri[0] == '\\')
        return refuse("absolute path");
    // RFC 3986 §3.1: scheme = ALPHA *( ALPHA / DIGIT / "+" / "-" / "." ) ":". A drive letter
    // ("C:") has the same shape and is refused too.
    if (std::isalpha(static_cast<unsigned char>(uri[0]))) {
        std::size_t i = 1;
        while (i < uri.size() && (std::isalnum(static_cast<unsigned char>(uri[i])) ||
                                  uri[i] == '+' || uri[i] == '-' || uri[i] == '.')) {
            ++i;
        }
        if (i < uri.size() && uri[i] == ':')
            return refuse("URI with a scheme");
    }
    if (uri.find('\0') != std::string_view::npos)
        return refuse("NUL byte");
    return {};
}

std::size_t add_fan(TriangleMesh& mesh, const std::vector<std::uint32_t>& poly) {
    for (std::size_t i = 1; i + 1 < poly.size(); ++i) {
        mesh.triangles.push_back({poly[0], poly[i], poly[i + 1]});
    }
    return poly.size() < 3 ? 0 : poly.size() - 2;
}

Status finish_model(LoadedModel& model, std::string_view name, const LoadLimits& limits) {
    // Names and messages quote the file's bytes, in whatever encoding it was written: made
    // UTF-8 here, once for every format, since answers carry them as JSON strings (a Latin-1
    // material library name had made registration answer 500).
    for (ModelPart& part : model.parts)
        part.name = valid_utf8(part.name);
    for (std::string& n : model.material_names)
        n = valid_utf8(n);
    for (std::string& w : model.warnings)
        w = valid_utf8(w);
    std::size_t vertices = 0;
    for (ModelPart& part : model.parts) {
        vertices += part.mesh.positions.size();
        for (std::size_t v = 0; v < part.mesh.positions.size(); ++v) {
            if (!is_finite(part.mesh.positions[v])) {
                return load_error(name, "part '" + part.name + "' vertex " + std::to_string(v) +
                                            " has a non-finite coordinate");
            }
        }
        const auto& normals = part.mesh.normals;
        if (!std::all_of(normals.begin(), normals.end(),
                         [](const Vec3f& n) { return is_finite(n); })) {
            model.warnings.push_back("part '" + part.name +
                                     "': non-finite normals; normals dropped");
            part.mesh.normals.clear();
        }
    }
    const std::size_t triangles = model.triangle_count();
    if (triangles > limits.max_triangles || vertices > limits.max_vertices) {
        return Status::error(Code::too_large, std::string(name) + ": " + std::to_string(triangles) +
                                                  " triangles and " + std::to_string(vertices) +
                                                  " vertices exceed the limits (" +
                                                  std::to_string(limits.max_triangles) + ", " +
                                                  std::to_string(limits.max_vertices) + ")");
    }
    if (triangles == 0)
        model.warnings.push_back(std::string(name) + " has no triangles");
    return {};
}

}  // namespace detail

}  // namespace raycastd::engine
