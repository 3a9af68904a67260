#include "server/schema/render_doc.h"

#include <cmath>

#include "server/schema/json_writer.h"
#include "server/schema/query_doc.h"
#include "server/schema/scene_doc.h"

namespace raycastd::server {

namespace {

constexpr ErrorCode kInvalid = ErrorCode::invalid_request;
constexpr int kMaxSide = 16384;
constexpr int kMaxSpp = 4096;
constexpr int kMaxDepth = 32;
constexpr double kMaxBackground = 1e6;  ///< a linear intensity, far above any display

int read_int(const Json& body, const char* key, int fallback, int lo, int hi) {
    const Json* v = member(body, key);
    if (!v)
        return fallback;
    const std::string path = std::string("/") + key;
    const double x = read_number(*v, path, kInvalid);
    if (x != std::floor(x) || x < lo || x > hi) {
        throw ApiError(kInvalid,
                       path + " must be an integer in [" + std::to_string(lo) + ", " +
                           std::to_string(hi) + "]",
                       path);
    }
    return static_cast<int>(x);
}

engine::Precision read_precision(const Json& body, engine::Precision absent) {
    const Json* p = member(body, "precision");
    if (!p)
        return absent;
    return parse_precision(read_string(*p, "/precision", kInvalid), "/precision");
}

void write_node(JsonWriter& w, const engine::Scene& scene, const engine::RayTree& tree, int k) {
    if (k < 0) {
        w.raw("null");
        return;
    }
    const engine::TreeNode& n = tree.nodes[static_cast<std::size_t>(k)];
    const engine::Object& o = scene.objects[n.hit.object];
    w.raw("{\"label\":").string("I" + std::to_string(k + 1));
    w.raw(",\"object\":").integer(n.hit.object);
    w.raw(",\"name\":").string(o.name);
    w.raw(",\"t\":").number(n.hit.t);
    w.raw(",\"point\":").vec(n.point);
    w.raw(",\"normal\":").vec(n.normal);
    w.raw(",\"front_face\":").boolean(n.hit.front_face);
    w.raw(",\"shadow_rays\":[");
    for (std::size_t i = 0; i < n.shadow_rays.size(); ++i) {
        const engine::ShadowRayRecord& s = n.shadow_rays[i];
        if (i)
            w.ch(',');
        w.raw("{\"light\":").integer(s.light).raw(",\"blocked_by\":");
        if (s.blocked_by == engine::kInvalidId) {
            w.raw("null");
        } else {
            w.string(scene.objects[s.blocked_by].name);
        }
        w.raw(",\"facing\":").boolean(s.facing).ch('}');
    }
    w.raw("],\"terms\":");
    w.raw(n.full_phong ? R"(["ambient","diffuse","specular"])" : R"(["ambient"])");
    w.raw(",\"color\":").vec(n.color);
    if (n.total_internal_reflection)
        w.raw(",\"total_internal_reflection\":true");
    w.raw(",\"reflected\":");
    write_node(w, scene, tree, n.reflected);
    w.raw(",\"refracted\":");
    write_node(w, scene, tree, n.refracted);
    w.ch('}');
}

void write_labels(JsonWriter& w, const engine::RayTree& tree, bool full) {
    w.ch('[');
    bool first = true;
    for (std::size_t k = 0; k < tree.nodes.size(); ++k) {
        if (tree.nodes[k].full_phong != full)
            continue;
        if (!first)
            w.ch(',');
        first = false;
        w.string("I" + std::to_string(k + 1));
    }
    w.ch(']');
}

/// The members of a render body over the defaults already in `r`.
void read_render_members(const Json& body, RenderRequest& r) {
    engine::RenderOptions& o = r.options;
    require_object(body, "", kInvalid);
    o.width = read_int(body, "width", o.width, 1, kMaxSide);
    o.height = read_int(body, "height", o.height, 1, kMaxSide);
    o.spp = read_int(body, "spp", o.spp, 1, kMaxSpp);
    o.whitted.max_depth = read_int(body, "max_depth", o.whitted.max_depth, 1, kMaxDepth);
    o.whitted.precision = read_precision(body, o.whitted.precision);
    if (const Json* v = member(body, "background")) {
        // A linear colour, as a material's: not negative, and not so large that a float image
        // (PFM, EXR) holds inf for it (1e308 had been written so; an adversarial review).
        const engine::Vec3d c = read_vec3(*v, "/background", kInvalid);
        for (const double x : {c.x, c.y, c.z}) {
            if (!(x >= 0.0 && x <= kMaxBackground)) {
                throw ApiError(kInvalid, "/background must be three numbers in [0, 1e6]",
                               "/background");
            }
        }
        o.whitted.background = c;
    }
    if (const Json* v = member(body, "camera"))
        o.camera = parse_camera(*v, "/camera", kInvalid);
    if (const Json* v = member(body, "shading")) {
        const std::string s = read_string(*v, "/shading", kInvalid);
        const auto mode = engine::shading_mode_from_name(s);
        if (!mode) {
            throw ApiError(kInvalid,
                           "unknown shading \"" + s +
                               "\" (expected phong, normal, depth, object_id, barycentric)",
                           "/shading");
        }
        o.shading = *mode;
    }
    if (const Json* v = member(body, "sampling")) {
        const std::string s = read_string(*v, "/sampling", kInvalid);
        if (s != "uniform" && s != "adaptive") {
            throw ApiError(kInvalid, "unknown sampling \"" + s + "\" (expected uniform, adaptive)",
                           "/sampling");
        }
        o.adaptive = s == "adaptive";
    }
    if (const Json* v = member(body, "lighting")) {
        const std::string s = read_string(*v, "/lighting", kInvalid);
        const auto lighting = engine::lighting_from_name(s);
        if (!lighting) {
            throw ApiError(kInvalid,
                           "unknown lighting \"" + s + "\" (expected scene, headlight, auto)",
                           "/lighting");
        }
        o.lighting = *lighting;
    }
    if (const Json* v = member(body, "format")) {
        const std::string s = read_string(*v, "/format", kInvalid);
        const auto f = engine::image_format_from_name(s);
        if (!f) {
            throw ApiError(ErrorCode::unsupported_format,
                           "unknown image format \"" + s + "\" (expected png, ppm, pfm, exr)",
                           "/format");
        }
        r.format = *f;
    }
    if (const Json* v = member(body, "async")) {
        if (!v->is_boolean())
            throw ApiError(kInvalid, "/async must be a boolean", "/async");
        r.async = v->get<bool>();
    }
}

}  // namespace

RenderRequest parse_render_request(const Json& body, std::size_t max_pixels) {
    RenderRequest r;
    engine::RenderOptions& o = r.options;
    // A preview defaults to fast: an 8-bit pixel cannot show the digits refined adds (float
    // hits are within ~1e-7 of the scene's size; spawned rays are offset by each precision's
    // own error bound, so no acne at any precision), and fast renders 1.5-3x sooner
    // (docs/rendering.md). Ray trees default to refined, like intersect: their t are read.
    o.whitted.precision = engine::Precision::fast;
    if (!body.is_null())
        read_render_members(body, r);
    // The limit holds for the defaults too (an empty body), whatever --max-pixels is.
    const std::size_t samples = static_cast<std::size_t>(o.width) *
                                static_cast<std::size_t>(o.height) *
                                static_cast<std::size_t>(o.spp);
    if (samples > max_pixels) {
        throw ApiError(ErrorCode::too_large, "width × height × spp = " + std::to_string(samples) +
                                                 " is over the limit of " +
                                                 std::to_string(max_pixels));
    }
    return r;
}

engine::Ray parse_single_ray(const Json& body, const std::string& path) {
    const Json* r = member(body, "ray");
    if (!r)
        throw ApiError(kInvalid, path + " is required", path);
    if (!r->is_object())
        throw ApiError(ErrorCode::invalid_ray, path + " must be an object", path);
    engine::Ray ray;
    const Json* o = member(*r, "origin");
    const Json* d = member(*r, "direction");
    if (!o)
        throw ApiError(ErrorCode::invalid_ray, path + "/origin is required", path + "/origin");
    if (!d)
        throw ApiError(ErrorCode::invalid_ray, path + "/direction is required",
                       path + "/direction");
    ray.origin = read_vec3(*o, path + "/origin", ErrorCode::invalid_ray);
    ray.direction = read_vec3(*d, path + "/direction", ErrorCode::invalid_ray);
    if (const Json* v = member(*r, "tmin"))
        ray.tmin = read_number(*v, path + "/tmin", ErrorCode::invalid_ray);
    if (const Json* v = member(*r, "tmax"))
        ray.tmax = read_number(*v, path + "/tmax", ErrorCode::invalid_ray);
    engine::Status st = engine::validate_ray(ray, 0);
    if (!st.ok()) {
        const auto slash = st.path.find('/', std::string("/rays/0").size());
        throw ApiError(ErrorCode::invalid_ray,
                       "the ray is invalid: " + st.message.substr(st.message.find(": ") + 2),
                       path + (slash == std::string::npos ? "" : st.path.substr(slash)));
    }
    return ray;
}

TraceRequest parse_trace_request(const Json& body) {
    require_object(body, "", kInvalid);
    TraceRequest t;
    t.ray = parse_single_ray(body, "/ray");
    t.options.max_depth = read_int(body, "max_depth", t.options.max_depth, 1, kMaxDepth);
    t.options.precision = read_precision(body, engine::Precision::refined);
    return t;
}

std::string write_trace_json(const engine::Scene& scene, const engine::RayTree& tree,
                             engine::Precision precision) {
    std::string out;
    JsonWriter w(out);
    w.raw("{\"tree\":");
    write_node(w, scene, tree, tree.nodes.empty() ? -1 : 0);
    w.raw(",\"summary\":{\"points\":").integer(tree.nodes.size());
    w.raw(",\"full_phong\":");
    write_labels(w, tree, true);
    w.raw(",\"ambient_only\":");
    write_labels(w, tree, false);
    w.raw("},\"color\":").vec(tree.color);
    w.raw(",\"rays\":{\"primary\":").integer(tree.counts.primary);
    w.raw(",\"shadow\":").integer(tree.counts.shadow);
    w.raw(",\"reflected\":").integer(tree.counts.reflected);
    w.raw(",\"refracted\":").integer(tree.counts.refracted);
    w.raw("},\"precision\":").string(engine::to_string(precision)).ch('}');
    return out;
}

std::string rays_header(const engine::RayCounts& c) {
    return "primary=" + std::to_string(c.primary) + ", shadow=" + std::to_string(c.shadow) +
           ", reflected=" + std::to_string(c.reflected) +
           ", refracted=" + std::to_string(c.refracted);
}

}  // namespace raycastd::server
