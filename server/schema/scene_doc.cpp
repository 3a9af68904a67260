#include "server/schema/scene_doc.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <map>

#include "engine/format.h"

namespace raycastd::server {

void warn_unknown_keys(const Json& j, const std::string& path,
                       std::initializer_list<const char*> known, engine::Scene& scene) {
    for (auto it = j.begin(); it != j.end(); ++it) {
        if (std::none_of(known.begin(), known.end(),
                         [&](const char* k) { return it.key() == k; })) {
            scene.warnings.push_back("unknown key " + child_path(path, it.key()) + " ignored");
        }
    }
}

namespace {

using engine::Scene;
using engine::Vec3d;
constexpr ErrorCode kInvalid = ErrorCode::invalid_scene;

double read_in_range(const Json& obj, const char* key, const std::string& path, double fallback,
                     double lo, double hi, const char* what) {
    const Json* v = member(obj, key);
    if (!v)
        return fallback;
    const std::string p = child_path(path, key);
    const double x = read_number(*v, p, kInvalid);
    if (x < lo || x > hi)
        throw ApiError(kInvalid, p + " must be " + what, p);
    return x;
}

Vec3d read_color(const Json& obj, const char* key, const std::string& path, const Vec3d& fallback) {
    const Json* v = member(obj, key);
    if (!v)
        return fallback;
    const std::string p = child_path(path, key);
    const Vec3d c = read_vec3(*v, p, kInvalid);
    if (c.x < 0 || c.y < 0 || c.z < 0)
        throw ApiError(kInvalid, p + " must be ≥ 0", p);
    return c;
}

engine::Material parse_material(const Json& j, const std::string& path, Scene& scene) {
    require_object(j, path, kInvalid);
    warn_unknown_keys(j, path,
                      {"ambient", "diffuse", "specular", "shininess", "reflectivity",
                       "transparency", "ior", "emissive"},
                      scene);
    engine::Material m;
    m.ambient = read_color(j, "ambient", path, m.ambient);
    m.diffuse = read_color(j, "diffuse", path, m.diffuse);
    m.specular = read_color(j, "specular", path, m.specular);
    m.emissive = read_color(j, "emissive", path, m.emissive);
    m.shininess = read_in_range(j, "shininess", path, m.shininess, 0, 1e6, "in [0, 1e6]");
    m.reflectivity = read_in_range(j, "reflectivity", path, 0, 0, 1, "in [0, 1]");
    m.transparency = read_in_range(j, "transparency", path, 0, 0, 1, "in [0, 1]");
    m.ior = read_in_range(j, "ior", path, 1, 1e-3, 1e3, "in [0.001, 1000]");
    return m;
}

void parse_materials(const Json& doc, const std::string& prefix, Scene& scene,
                     std::map<std::string, std::uint32_t>& by_name) {
    scene.materials.push_back(engine::Material{});  // 0: the default grey Phong material
    scene.material_names.push_back("default");
    const Json* mats = member(doc, "materials");
    if (!mats)
        return;
    const std::string path = prefix + "/materials";
    require_object(*mats, path, kInvalid);
    for (auto it = mats->begin(); it != mats->end(); ++it) {
        const std::string p = child_path(path, it.key());
        by_name[it.key()] = static_cast<std::uint32_t>(scene.materials.size());
        scene.materials.push_back(parse_material(it.value(), p, scene));
        scene.material_names.push_back(it.key());
    }
}

engine::Light parse_light(const Json& j, const std::string& path, Scene& scene) {
    require_object(j, path, kInvalid);
    warn_unknown_keys(j, path, {"type", "position", "direction", "intensity", "name"}, scene);
    const Json* type = member(j, "type");
    if (!type)
        throw ApiError(kInvalid, path + "/type is required", path + "/type");
    const std::string t = read_string(*type, path + "/type", kInvalid);
    engine::Light l;
    l.intensity = read_color(j, "intensity", path, l.intensity);
    if (t == "ambient") {
        l.type = engine::LightType::ambient;
    } else if (t == "point") {
        l.type = engine::LightType::point;
        const Json* pos = member(j, "position");
        if (!pos)
            throw ApiError(kInvalid, path + "/position is required", path + "/position");
        l.position = read_vec3(*pos, path + "/position", kInvalid);
    } else if (t == "directional") {
        l.type = engine::LightType::directional;
        const Json* dir = member(j, "direction");
        if (!dir)
            throw ApiError(kInvalid, path + "/direction is required", path + "/direction");
        l.direction = read_vec3(*dir, path + "/direction", kInvalid);
        if (l.direction == Vec3d{0, 0, 0}) {
            throw ApiError(kInvalid, path + "/direction must not be zero", path + "/direction");
        }
    } else {
        throw ApiError(kInvalid,
                       "unknown light type \"" + t + "\" (expected ambient, point, directional)",
                       path + "/type");
    }
    return l;
}

engine::Object parse_object(const Json& j, const std::string& path, std::size_t index, Scene& scene,
                            const std::map<std::string, std::uint32_t>& materials,
                            const MeshObjectLoader& load_mesh) {
    require_object(j, path, kInvalid);
    const Json* type = member(j, "type");
    if (!type)
        throw ApiError(kInvalid, path + "/type is required", path + "/type");
    const std::string t = read_string(*type, path + "/type", kInvalid);
    engine::Object o;
    if (t == "sphere") {
        warn_unknown_keys(j, path, {"type", "name", "material", "center", "radius"}, scene);
        o.kind = engine::ObjectKind::sphere;
        const Json* c = member(j, "center");
        if (!c)
            throw ApiError(kInvalid, path + "/center is required", path + "/center");
        o.sphere.center = read_vec3(*c, path + "/center", kInvalid);
        const Json* r = member(j, "radius");
        if (!r)
            throw ApiError(kInvalid, path + "/radius is required", path + "/radius");
        o.sphere.radius = read_number(*r, path + "/radius", kInvalid);
        if (!(o.sphere.radius > 0)) {
            throw ApiError(kInvalid,
                           "objects[" + std::to_string(index) + "].radius must be > 0, got " +
                               engine::format_shortest(o.sphere.radius),
                           path + "/radius");
        }
    } else if (t == "triangle") {
        warn_unknown_keys(j, path, {"type", "name", "material", "vertices"}, scene);
        o.kind = engine::ObjectKind::triangle;
        const Json* v = member(j, "vertices");
        const std::string vp = path + "/vertices";
        if (!v || !v->is_array() || v->size() != 3) {
            throw ApiError(kInvalid, vp + " must be an array of 3 points", vp);
        }
        auto mesh = std::make_shared<engine::TriangleMesh>();
        for (std::size_t k = 0; k < 3; ++k) {
            mesh->positions.push_back(read_vec3(v->at(k), child_path(vp, k), kInvalid));
        }
        mesh->triangles.push_back({0, 1, 2});
        o.mesh = std::move(mesh);
    } else if (t == "mesh") {
        warn_unknown_keys(
            j, path,
            {"type", "name", "material", "uri", "data_base64", "format", "files", "transform"},
            scene);
        if (!load_mesh) {
            throw ApiError(kInvalid, "mesh objects cannot be loaded here", path + "/type");
        }
        o.kind = engine::ObjectKind::mesh;
        o.mesh = load_mesh(j, path, scene);
    } else {
        throw ApiError(kInvalid,
                       "unknown object type \"" + t + "\" (expected sphere, triangle, mesh)",
                       path + "/type");
    }
    o.name = (t == "mesh" ? std::string("mesh") : t) + " " + std::to_string(index + 1);
    if (const Json* n = member(j, "name"))
        o.name = read_string(*n, path + "/name", kInvalid);
    if (const Json* m = member(j, "material")) {
        const std::string name = read_string(*m, path + "/material", kInvalid);
        auto it = materials.find(name);
        if (it == materials.end()) {
            throw ApiError(kInvalid, "material \"" + name + "\" is not defined in /materials",
                           path + "/material");
        }
        o.material = it->second;
    }
    return o;
}

}  // namespace

const char* default_view_name(engine::DefaultView view) {
    return view == engine::DefaultView::from_plus_z ? "+z" : "-z";
}

std::optional<engine::DefaultView> default_view_from_name(std::string_view name) {
    if (name == "+z")
        return engine::DefaultView::from_plus_z;
    if (name == "-z")
        return engine::DefaultView::from_minus_z;
    return std::nullopt;
}

engine::Camera parse_camera(const Json& j, const std::string& path, ErrorCode code) {
    require_object(j, path, code);
    engine::Camera c;
    if (const Json* v = member(j, "position"))
        c.position = read_vec3(*v, path + "/position", code);
    if (const Json* v = member(j, "look_at"))
        c.look_at = read_vec3(*v, path + "/look_at", code);
    if (const Json* v = member(j, "up"))
        c.up = read_vec3(*v, path + "/up", code);
    if (const Json* v = member(j, "fov_y_deg")) {
        c.fov_y_deg = read_number(*v, path + "/fov_y_deg", code);
        if (!(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0)) {
            throw ApiError(code, path + "/fov_y_deg must be in (0, 180)", path + "/fov_y_deg");
        }
    }
    if (c.look_at == c.position) {
        throw ApiError(code, path + "/look_at must differ from position", path + "/look_at");
    }
    const engine::Vec3d view = c.look_at - c.position;
    if (!is_finite(view)) {
        throw ApiError(code,
                       path + "/look_at is too far from position (their difference overflows)",
                       path + "/look_at");
    }
    // On unit vectors (normalize() rescales tiny and huge ones): the cross product of a view
    // direction 1e-300 long with up underflowed to 0, and such a camera was refused as parallel.
    if (length(cross(normalize(view), normalize(c.up))) == 0.0) {
        throw ApiError(code, path + "/up must not be parallel to the view direction", path + "/up");
    }
    return c;
}

engine::Scene parse_scene_doc(const Json& doc, const std::string& prefix,
                              const MeshObjectLoader& load_mesh) {
    require_object(doc, prefix, kInvalid);
    Scene scene;
    warn_unknown_keys(doc, prefix, {"objects", "materials", "lights", "camera", "name"}, scene);
    std::map<std::string, std::uint32_t> materials;
    parse_materials(doc, prefix, scene, materials);

    const Json* objects = member(doc, "objects");
    const std::string opath = prefix + "/objects";
    if (!objects)
        throw ApiError(kInvalid, opath + " is required", opath);
    if (!objects->is_array())
        throw ApiError(kInvalid, opath + " must be an array", opath);
    for (std::size_t i = 0; i < objects->size(); ++i) {
        scene.objects.push_back(
            parse_object(objects->at(i), child_path(opath, i), i, scene, materials, load_mesh));
    }
    if (const Json* lights = member(doc, "lights")) {
        const std::string lpath = prefix + "/lights";
        if (!lights->is_array())
            throw ApiError(kInvalid, lpath + " must be an array", lpath);
        for (std::size_t i = 0; i < lights->size(); ++i) {
            scene.lights.push_back(parse_light(lights->at(i), child_path(lpath, i), scene));
        }
    }
    if (const Json* cam = member(doc, "camera")) {
        const std::string cpath = prefix + "/camera";
        if (cam->is_object()) {
            warn_unknown_keys(*cam, cpath, {"position", "look_at", "up", "fov_y_deg"}, scene);
        }
        scene.camera = parse_camera(*cam, cpath, kInvalid);
    }
    engine::Status st = engine::validate(scene);
    if (!st.ok())
        throw from_status(st, prefix);
    return scene;
}

}  // namespace raycastd::server
