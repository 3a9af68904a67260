// POST /v1/explain: the tutorial's worked solution (JSON, or Markdown with ?format=markdown).

#include "engine/explain/explain.h"
#include "engine/query/intersect.h"
#include "server/app.h"
#include "server/schema/explain_doc.h"

namespace raycastd::server {

namespace {

engine::Ray parse_single_ray(const Json& body, const std::string& path) {
    const Json* r = member(body, "ray");
    if (!r) throw api_error("invalid_request", path + " is required", path);
    if (!r->is_object()) throw api_error("invalid_ray", path + " must be an object", path);
    engine::Ray ray;
    const Json* o = member(*r, "origin");
    const Json* d = member(*r, "direction");
    if (!o) throw api_error("invalid_ray", path + "/origin is required", path + "/origin");
    if (!d) throw api_error("invalid_ray", path + "/direction is required", path + "/direction");
    ray.origin = read_vec3(*o, path + "/origin", "invalid_ray");
    ray.direction = read_vec3(*d, path + "/direction", "invalid_ray");
    if (const Json* v = member(*r, "tmin")) ray.tmin = read_number(*v, path + "/tmin", "invalid_ray");
    if (const Json* v = member(*r, "tmax")) ray.tmax = read_number(*v, path + "/tmax", "invalid_ray");
    engine::Status st = engine::validate_ray(ray, 0);
    if (!st.ok()) {
        const auto slash = st.path.find('/', std::string("/rays/0").size());
        throw api_error("invalid_ray", "the ray is invalid: " + st.message.substr(st.message.find(": ") + 2),
                        path + (slash == std::string::npos ? "" : st.path.substr(slash)));
    }
    return ray;
}

}  // namespace

void install_trace_routes(App& app) {
    app.http().Post("/v1/explain", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, true, [&] {
            const std::string format = req.has_param("format") ? req.get_param_value("format") : "json";
            if (format != "json" && format != "markdown") {
                throw api_error("unsupported_format",
                                "format must be json or markdown, got \"" + format + "\"");
            }
            const Json body = App::parse_json_body(req);
            require_object(body, "", "invalid_request");
            const Json* scene_doc = member(body, "scene");
            if (!scene_doc) throw api_error("invalid_request", "/scene is required", "/scene");
            auto engine = app.build_stateless_scene(*scene_doc, "/scene");
            const engine::Ray ray = parse_single_ray(body, "/ray");
            const engine::Explanation ex = engine::explain(engine->scene(), ray);
            if (format == "markdown") {
                res.status = 200;
                res.set_content(write_explain_markdown(ex, ray), "text/markdown; charset=utf-8");
            } else {
                send_json(res, write_explain_json(ex, ray));
            }
        });
    });
}

}  // namespace raycastd::server
