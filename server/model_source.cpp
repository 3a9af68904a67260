#include "server/model_source.h"

#include <algorithm>
#include <cctype>
#include <map>
#include <memory>
#include <set>

#include "engine/math/transform.h"
#include "server/schema/scene_doc.h"
#include "server/uri_resolver.h"

namespace raycastd::server {

namespace {

/// A failed read or load, reported at `path` (the object's pointer, not the Status's own).
ApiError load_error(const engine::Status& st, const std::string& path) {
    ApiError e = from_status(st);
    e.path = path;
    return e;
}

engine::Transform parse_transform(const Json& j, const std::string& path) {
    require_object(j, path, ErrorCode::invalid_scene);
    engine::Vec3d translate{0, 0, 0}, rotate{0, 0, 0}, scale{1, 1, 1};
    if (const Json* t = member(j, "translate"))
        translate = read_vec3(*t, path + "/translate", ErrorCode::invalid_scene);
    if (const Json* r = member(j, "rotate_deg"))
        rotate = read_vec3(*r, path + "/rotate_deg", ErrorCode::invalid_scene);
    if (const Json* s = member(j, "scale")) {
        if (s->is_number()) {
            const double k = read_number(*s, path + "/scale", ErrorCode::invalid_scene);
            scale = {k, k, k};
        } else {
            scale = read_vec3(*s, path + "/scale", ErrorCode::invalid_scene);
        }
        if (scale.x == 0 || scale.y == 0 || scale.z == 0) {
            throw ApiError(ErrorCode::invalid_scene, path + "/scale must not be zero",
                           path + "/scale");
        }
    }
    return engine::Transform::from_translate_rotate_scale(translate, rotate, scale);
}

/// Concatenates a model's parts into one mesh; model material k becomes scene material
/// `material_base + k`, and triangles without a material take `fallback`.
std::shared_ptr<engine::TriangleMesh> merge_parts(const engine::LoadedModel& model,
                                                  std::uint32_t material_base,
                                                  std::uint32_t fallback) {
    auto mesh = std::make_shared<engine::TriangleMesh>();
    const bool all_normals = std::all_of(model.parts.begin(), model.parts.end(),
                                         [](const auto& p) { return !p.mesh.normals.empty(); });
    const bool any_material = !model.materials.empty();
    const bool any_uvs = std::any_of(model.parts.begin(), model.parts.end(),
                                     [](const auto& p) { return !p.mesh.corner_uvs.empty(); });
    for (const auto& part : model.parts) {
        const auto base = static_cast<std::uint32_t>(mesh->positions.size());
        mesh->positions.insert(mesh->positions.end(), part.mesh.positions.begin(),
                               part.mesh.positions.end());
        if (all_normals) {
            mesh->normals.insert(mesh->normals.end(), part.mesh.normals.begin(),
                                 part.mesh.normals.end());
        }
        for (std::size_t t = 0; t < part.mesh.triangles.size(); ++t) {
            const auto& tri = part.mesh.triangles[t];
            mesh->triangles.push_back({tri[0] + base, tri[1] + base, tri[2] + base});
            if (any_material) {
                mesh->triangle_material.push_back(part.mesh.triangle_material.empty()
                                                      ? fallback
                                                      : material_base +
                                                            part.mesh.triangle_material[t]);
            }
            if (any_uvs) {
                mesh->corner_uvs.push_back(part.mesh.corner_uvs.empty()
                                               ? std::array<std::array<float, 2>, 3>{}
                                               : part.mesh.corner_uvs[t]);
            }
        }
    }
    return mesh;
}

/// A path an inline model gives (or a `files` key, or a `uri`), as `files` holds it: Windows
/// separators turned into '/', then normalised as a scene-root path is (uri_resolver.h).
engine::Result<std::string> inline_file_path(std::string path) {
    std::replace(path.begin(), path.end(), '\\', '/');
    return normalize_relative(path);
}

/// The `files` of an inline mesh object: {relative path: base64 bytes}, the files its model
/// names (an OBJ's .mtl and map_Kd images, a .gltf's buffers and images), each looked up by the
/// path the model gives, relative to the model, normalised as a scene-root path is ("./a\b"
/// and "a/b" are one file; an absolute path, a scheme or a ".." above the model is refused, as
/// for `uri`). Their bytes count against the body limit like the rest of the document.
std::map<std::string, std::string> read_inline_files(const Json& files, const std::string& path) {
    if (!files.is_object())
        throw ApiError(ErrorCode::invalid_scene, path + " must be an object", path);
    std::map<std::string, std::string> out;
    for (const auto& [name, value] : files.items()) {
        const std::string at = child_path(path, name);
        auto norm = inline_file_path(name);
        if (!norm.ok()) {
            throw ApiError(ErrorCode::invalid_scene,
                           at + ": not a path relative to the model (it is absolute, has a "
                                "scheme or drive, or climbs above the model's folder)",
                           at);
        }
        if (!value.is_string())
            throw ApiError(ErrorCode::invalid_scene, at + " must be a base64 string", at);
        auto bytes = decode_base64(value.get_ref<const std::string&>());
        if (!bytes)
            throw ApiError(ErrorCode::invalid_scene, at + " is not valid base64", at);
        if (!out.emplace(*norm, std::move(*bytes)).second) {
            throw ApiError(ErrorCode::invalid_scene, at + " names the same file as another entry",
                           at);
        }
    }
    return out;
}

/// A model file's camera has a position and a direction but no target (glTF 2.0 §3.10.1): once
/// the scene is assembled and placed (a document's transforms applied, its other objects in),
/// its look_at goes where its axis passes closest to the middle of the scene, the pivot the
/// preview page orbits about (engine/scene/camera.h aim_at).
void aim_model_camera(engine::Scene& scene) {
    const engine::Bounds3 b = scene.bounds();
    if (scene.camera && !b.empty())
        engine::aim_at(*scene.camera, b.center(), 0.5 * length(b.diagonal()));
}

void adopt_model_extras(engine::LoadedModel& model, const std::string& prefix,
                        engine::Scene& scene) {
    for (auto& l : model.lights)
        scene.lights.push_back(l);
    if (!scene.camera && model.camera)
        scene.camera = model.camera;
    for (auto& w : model.warnings)
        scene.warnings.push_back(prefix + w);
}

std::uint32_t adopt_materials(const engine::LoadedModel& model, const std::string& owner,
                              engine::Scene& scene) {
    const auto base = static_cast<std::uint32_t>(scene.materials.size());
    for (std::size_t k = 0; k < model.materials.size(); ++k) {
        scene.materials.push_back(model.materials[k]);
        scene.material_names.push_back(owner + "/" + model.material_names[k]);
    }
    return base;
}

/// Pixels of the texture images a loaded model holds, each image once.
std::size_t decoded_texture_pixels(const engine::LoadedModel& model) {
    std::set<const engine::TextureImage*> seen;
    std::size_t pixels = 0;
    for (const engine::Material& m : model.materials) {
        if (m.texture && m.texture->image && seen.insert(m.texture->image.get()).second) {
            pixels += static_cast<std::size_t>(m.texture->image->width) *
                      static_cast<std::size_t>(m.texture->image->height);
        }
    }
    return pixels;
}

engine::LoadLimits load_limits(const Limits& limits) {
    engine::LoadLimits l;
    l.max_triangles = limits.max_triangles;
    // A mesh has at most about three vertices per triangle unless it is padding itself out.
    l.max_vertices = 3 * limits.max_triangles;
    l.max_texture_pixels = limits.max_texture_pixels;
    l.max_texture_pixels_total = 4 * limits.max_texture_pixels;
    return l;
}

}  // namespace

engine::Scene scene_from_document(const Json& doc, const std::string& prefix,
                                  const FileSource& files, const Limits& limits, bool textures) {
    // The texture budget (4 × --max-texture-pixels) is the scene's, shared by its mesh objects:
    // per object, a document of many small objects could each bring the most one may, and the
    // same image could come in under as many names (a document's `files`). A scene that is only
    // queried (textures false) decodes none.
    const std::size_t texture_budget = textures ? 4 * limits.max_texture_pixels : 0;
    std::size_t texture_pixels = 0;
    MeshObjectLoader load_mesh =
        [&](const Json& obj, const std::string& path,
            engine::Scene& scene) -> std::shared_ptr<const engine::TriangleMesh> {
        const Json* uri = member(obj, "uri");
        const Json* data = member(obj, "data_base64");
        const Json* fmt = member(obj, "format");
        if ((uri != nullptr) == (data != nullptr)) {
            throw ApiError(ErrorCode::invalid_scene,
                           path + ": a mesh needs exactly one of uri and data_base64", path);
        }
        if (uri && member(obj, "files")) {
            throw ApiError(ErrorCode::invalid_scene,
                           path +
                               "/files goes with data_base64: a model named by uri reads the "
                               "files it names beside it in the scene root",
                           path + "/files");
        }
        std::optional<engine::ModelFormat> format;
        if (fmt) {
            const std::string f = read_string(*fmt, path + "/format", ErrorCode::invalid_scene);
            format = engine::format_from_name(f);
            if (!format) {
                throw ApiError(ErrorCode::unsupported_format,
                               "format \"" + f + "\" is not one of gltf, glb, obj, ply, stl, off",
                               path + "/format");
            }
        }
        std::string bytes, display, dir;
        engine::ResourceReader resources = engine::no_resources();
        if (uri) {
            const std::string u = read_string(*uri, path + "/uri", ErrorCode::invalid_scene);
            // Windows separators too, as for `files` keys (docs/api.md: "spider\spider.obj"
            // had been refused as naming no file, though the docs said it was normalised).
            auto norm = inline_file_path(u);
            if (!norm.ok())
                throw ApiError(ErrorCode::invalid_scene, norm.status().message, path + "/uri");
            auto content = files(*norm);
            if (!content.ok())
                throw load_error(content.status(), path + "/uri");
            bytes = std::move(*content);
            display =
                norm->substr(norm->rfind('/') == std::string::npos ? 0 : norm->rfind('/') + 1);
            if (!format)
                format = engine::format_from_name(*norm);
            dir = dirname_of(*norm);
            resources = [&files, dir](const std::string& ref) -> engine::Result<std::string> {
                auto joined = join_relative(dir, ref);
                if (!joined.ok())
                    return joined.status();
                return files(*joined);
            };
        } else {
            if (!format) {
                throw ApiError(ErrorCode::invalid_scene,
                               path + "/format is required with data_base64", path + "/format");
            }
            if (!data->is_string()) {
                throw ApiError(ErrorCode::invalid_scene, path + "/data_base64 must be a string",
                               path + "/data_base64");
            }
            auto decoded = decode_base64(data->get_ref<const std::string&>());
            if (!decoded) {
                throw ApiError(ErrorCode::invalid_scene, path + "/data_base64 is not valid base64",
                               path + "/data_base64");
            }
            bytes = std::move(*decoded);
            display = "inline model";
            if (const Json* f = member(obj, "files")) {
                auto inline_files = std::make_shared<const std::map<std::string, std::string>>(
                    read_inline_files(*f, path + "/files"));
                resources = [inline_files](const std::string& ref) -> engine::Result<std::string> {
                    auto norm = inline_file_path(ref);
                    if (!norm.ok())
                        return norm.status();
                    auto it = inline_files->find(*norm);
                    if (it == inline_files->end()) {
                        return engine::Status::error(engine::Code::invalid_scene,
                                                     "no file " + *norm + " in /files");
                    }
                    return it->second;
                };
            }
        }
        if (!format)
            format = engine::sniff_format(bytes);
        if (!format) {
            throw ApiError(ErrorCode::unsupported_format,
                           path + ": cannot tell the model format; set \"format\"",
                           path + "/format");
        }
        if (const Json* n = member(obj, "name"); n && n->is_string())
            display = n->get<std::string>();
        engine::LoadLimits load = load_limits(limits);
        load.max_texture_pixels_total = texture_budget - texture_pixels;
        load.textures = textures;
        auto loaded = engine::load_model(bytes, *format, resources, display, load);
        if (!loaded.ok())
            throw load_error(loaded.status(), path);
        engine::LoadedModel& model = *loaded;
        texture_pixels += std::min(decoded_texture_pixels(model), texture_budget - texture_pixels);
        if (const Json* t = member(obj, "transform")) {
            engine::apply_transform(model, parse_transform(*t, path + "/transform"));
            // "rotate" for rotate_deg, "matrix": ignored, so said (a helper's review found
            // them silent, while a typo one level up was reported).
            warn_unknown_keys(*t, path + "/transform", {"translate", "rotate_deg", "scale"}, scene);
        }
        std::uint32_t fallback = 0;
        if (const Json* m = member(obj, "material"); m && m->is_string()) {
            // The object's own material (resolved by parse_object) applies to triangles the file
            // gives none; it is looked up here by name so the merge can use its index.
            auto it = std::find(scene.material_names.begin(), scene.material_names.end(),
                                m->get<std::string>());
            if (it != scene.material_names.end()) {
                fallback = static_cast<std::uint32_t>(it - scene.material_names.begin());
            }
        }
        const std::uint32_t base = adopt_materials(model, display, scene);
        adopt_model_extras(model, path + ": ", scene);
        return merge_parts(model, base, fallback);
    };
    engine::Scene scene = parse_scene_doc(doc, prefix, load_mesh);
    if (!member(doc, "camera"))
        aim_model_camera(scene);  // the camera, if any, is a model file's
    return scene;
}

engine::Scene scene_from_model(std::string_view bytes, engine::ModelFormat format,
                               const std::string& display_name, const Limits& limits) {
    auto loaded = engine::load_model(bytes, format, engine::no_resources(), display_name,
                                     load_limits(limits));
    if (!loaded.ok())
        throw load_error(loaded.status(), "");
    engine::LoadedModel& model = *loaded;
    engine::Scene scene;
    scene.materials.push_back(engine::Material{});
    scene.material_names.push_back("default");
    const std::uint32_t base = adopt_materials(model, display_name, scene);
    for (auto& part : model.parts) {
        engine::Object o;
        o.kind = engine::ObjectKind::mesh;
        o.name = part.name;
        auto mesh = std::make_shared<engine::TriangleMesh>(std::move(part.mesh));
        for (auto& m : mesh->triangle_material)
            m += base;
        o.mesh = std::move(mesh);
        scene.objects.push_back(std::move(o));
    }
    adopt_model_extras(model, "", scene);
    engine::Status st = engine::validate(scene);
    if (!st.ok()) {
        // A raw model body has no document to point into, and a file that parsed but cannot
        // be answered is API.md's 422 (e.g. vertices at ±1e308: an extent past double's).
        if (st.code == engine::Code::invalid_scene)
            throw ApiError(ErrorCode::model_load_failed, "the model: " + st.message);
        throw load_error(st, st.path);
    }
    aim_model_camera(scene);
    return scene;
}

namespace {

/// A Content-Type's media type without its parameters, trimmed and lower-cased (RFC 9110
/// §8.3.1: type and subtype are case-insensitive).
std::string media_type(const std::string& content_type) {
    std::string ct = content_type.substr(0, content_type.find(';'));
    ct.erase(0, ct.find_first_not_of(" \t"));
    ct.erase(ct.find_last_not_of(" \t") + 1);
    std::transform(ct.begin(), ct.end(), ct.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return ct;
}

}  // namespace

std::optional<engine::ModelFormat> format_from_content_type(const std::string& content_type) {
    const std::string ct = media_type(content_type);
    using F = engine::ModelFormat;
    if (ct == "model/gltf-binary")
        return F::glb;
    if (ct == "model/gltf+json")
        return F::gltf;
    if (ct == "model/obj" || ct == "text/x-obj" || ct == "application/x-tgif")
        return F::obj;
    if (ct == "application/sla" || ct == "model/stl" || ct == "application/vnd.ms-pki.stl" ||
        ct == "model/x.stl-binary" || ct == "model/x.stl-ascii") {
        return F::stl;
    }
    if (ct == "application/x-ply" || ct == "model/x-ply" || ct == "application/ply")
        return F::ply;
    if (ct == "model/off" || ct == "application/off" || ct == "model/x-off")
        return F::off;
    return std::nullopt;
}

std::optional<std::string> decode_base64(std::string_view text) {
    auto value = [](char c) -> int {
        if (c >= 'A' && c <= 'Z')
            return c - 'A';
        if (c >= 'a' && c <= 'z')
            return c - 'a' + 26;
        if (c >= '0' && c <= '9')
            return c - '0' + 52;
        if (c == '+' || c == '-')
            return 62;  // '-' and '_': the URL-safe alphabet (§5)
        if (c == '/' || c == '_')
            return 63;
        return -1;
    };
    std::string out;
    out.reserve(text.size() / 4 * 3);
    std::uint32_t acc = 0;
    int bits = 0;
    std::size_t padding = 0;
    for (char c : text) {
        if (std::isspace(static_cast<unsigned char>(c)))
            continue;
        if (c == '=') {
            ++padding;
            continue;
        }
        if (padding)
            return std::nullopt;  // data after padding
        const int v = value(c);
        if (v < 0)
            return std::nullopt;
        acc = (acc << 6) | static_cast<std::uint32_t>(v);
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            out.push_back(static_cast<char>((acc >> bits) & 0xFF));
        }
    }
    if (padding > 2 || bits >= 6)
        return std::nullopt;
    return out;
}

namespace {

std::shared_ptr<const engine::QueryEngine> prepare(engine::Scene scene, const Limits& limits,
                                                   const std::string& prefix,
                                                   const engine::CancelToken& cancel = {}) {
    if (scene.triangle_count() > limits.max_triangles) {
        throw ApiError(ErrorCode::too_large,
                       "the scene has " + std::to_string(scene.triangle_count()) +
                           " triangles, over the limit of " + std::to_string(limits.max_triangles),
                       prefix);
    }
    auto built =
        engine::QueryEngine::build(std::make_shared<engine::Scene>(std::move(scene)), cancel);
    if (!built.ok())
        throw from_status(built.status(), prefix);
    return *built;
}

}  // namespace

ModelSource::ModelSource(const Limits& limits, std::string scene_root)
    : limits_(limits), scene_root_(std::move(scene_root)) {}

FileSource ModelSource::scene_root_files() const {
    return
        [this](const std::string& path) { return scene_root_.read(path, limits_.max_body_bytes); };
}

std::shared_ptr<const engine::QueryEngine> ModelSource::build_stateless_scene(
    const Json& body, const engine::CancelToken& cancel) const {
    require_object(body, "", ErrorCode::invalid_request);
    const Json* doc = member(body, "scene");
    if (!doc)
        throw ApiError(ErrorCode::invalid_request, "/scene is required", "/scene");
    return stateless_cache_.get_or_build(*doc, [&] {
        // Stateless calls (intersect, explain, points) never render: no textures are decoded
        // for them, and the scenes the cache keeps hold none.
        return prepare(scene_from_document(*doc, "/scene", scene_root_files(), limits_, false),
                       limits_, "/scene", cancel);
    });
}

std::shared_ptr<const engine::QueryEngine> ModelSource::build_scene(const SceneSource& src,
                                                                    const FileSource& files) const {
    if (src.content_type == "application/json") {
        return prepare(scene_from_document(parse_json(src.body), "", files, limits_), limits_, "");
    }
    auto format = format_from_content_type(src.content_type);
    if (!format)
        throw ApiError(ErrorCode::unsupported_format, "cannot load " + src.content_type);
    return prepare(scene_from_model(src.body, *format, "model", limits_), limits_, "");
}

std::string classify_scene_body(std::string_view body, const std::string& content_type) {
    if (body.empty())
        return "application/json";
    // Normalised, as it is hashed into the scene's id: 'Model/OBJ' had given another id than
    // 'model/obj' for the same bytes (an adversarial review).
    const std::string ct = media_type(content_type);
    if (ct == "application/json")
        return ct;
    if (format_from_content_type(ct))
        return ct;
    if (!ct.empty() && ct != "application/octet-stream" &&
        ct != "application/x-www-form-urlencoded" && ct != "text/plain") {
        throw ApiError(ErrorCode::unsupported_format,
                       "Content-Type " + ct +
                           " is not a scene document (application/json) or a model type "
                           "(model/gltf-binary, model/gltf+json, model/obj, application/sla, "
                           "application/x-ply, model/off)");
    }
    // No usable type (curl -d sends form-urlencoded): tell by the bytes.
    if (auto f = engine::sniff_format(body)) {
        switch (*f) {
            case engine::ModelFormat::glb:
                return "model/gltf-binary";
            case engine::ModelFormat::ply:
                return "application/x-ply";
            case engine::ModelFormat::stl:
                return "application/sla";
            case engine::ModelFormat::off:
                return "model/off";
            case engine::ModelFormat::obj:
                return "model/obj";
            case engine::ModelFormat::gltf:
                break;  // JSON: a glTF or a scene document
        }
    }
    const auto first = body.find_first_not_of(" \t\r\n");
    if (first != std::string_view::npos && body[first] == '{') {
        // A glTF document has an "asset" object; a scene document has "objects". A body that
        // is not JSON is a scene document whose error parse_json reports.
        const std::optional<Json> j = try_parse_json(body);
        if (j && j->is_object() && j->contains("asset") && !j->contains("objects"))
            return "model/gltf+json";
        return "application/json";
    }
    throw ApiError(ErrorCode::unsupported_format, "cannot tell what the body is; set Content-Type");
}

}  // namespace raycastd::server
