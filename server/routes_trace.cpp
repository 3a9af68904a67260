// POST /v1/scenes/{id}/trace: the Whitted ray tree of one ray.
// POST /v1/explain: the tutorial's worked solution (JSON, or Markdown with ?format=markdown).

#include "engine/explain/explain.h"
#include "engine/query/intersect.h"
#include "engine/shade/whitted.h"
#include "server/app.h"
#include "server/schema/explain_doc.h"
#include "server/schema/render_doc.h"

namespace raycastd::server {

void install_trace_routes(App& app) {
    app.http().Post(R"(/v1/scenes/([A-Za-z0-9_]+)/trace)", [&app](const httplib::Request& req,
                                                                  httplib::Response& res) {
        app.handle(req, res, true, [&] {
            auto engine = app.scene_or_404(req.matches[1]);
            const TraceRequest t = parse_trace_request(App::parse_json_body(req));
            const engine::Whitted whitted(*engine, t.options);
            const engine::RayTree tree = whitted.tree(t.ray);
            send_json(res, write_trace_json(engine->scene(), tree,
                                            engine->effective_precision(t.options.precision)));
        });
    });
    app.http().Post("/v1/explain", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, true, [&] {
            const std::string format =
                req.has_param("format") ? req.get_param_value("format") : "json";
            if (format != "json" && format != "markdown") {
                throw api_error("unsupported_format",
                                "format must be json or markdown, got \"" + format + "\"");
            }
            const Json body = App::parse_json_body(req);
            require_object(body, "", "invalid_request");
            const Json* scene_doc = member(body, "scene");
            if (!scene_doc)
                throw api_error("invalid_request", "/scene is required", "/scene");
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
