// POST /v1/scenes/{id}/trace: the Whitted ray tree of one ray.
// POST /v1/explain: the tutorial's worked solution (JSON, or Markdown with ?format=markdown).

#include "engine/explain/explain.h"
#include "engine/query/intersect.h"
#include "engine/shade/whitted.h"
#include "server/app.h"
#include "server/request_cancel.h"
#include "server/request_log.h"
#include "server/schema/explain_doc.h"
#include "server/schema/render_doc.h"

namespace raycastd::server {

void install_trace_routes(App& app) {
    app.on_post(R"(/v1/scenes/([A-Za-z0-9_]+)/trace)", [&app](const httplib::Request& req,
                                                              httplib::Response& res) {
        app.handle(req, res, Work::heavy, [&] {
            const auto cancel = RequestCancel::for_current_request(app.config().limits);
            auto engine = app.scene_or_404(req.matches[1]);
            const TraceRequest t = parse_trace_request(parse_json(req.body));
            const engine::Whitted whitted(*engine, t.options);
            const auto tree = whitted.tree(t.ray, cancel.token());
            const engine::RayTree& rt = cancel.check(tree);
            const engine::Precision precision = engine->effective_precision(t.options.precision);
            note_rays(RayKind::primary, precision, rt.counts.primary);
            note_rays(RayKind::shadow, precision, rt.counts.shadow);
            note_rays(RayKind::reflected, precision, rt.counts.reflected);
            note_rays(RayKind::refracted, precision, rt.counts.refracted);
            send_json(res, write_trace_json(engine->scene(), rt, precision));
        });
    });
    app.on_post("/v1/explain", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, Work::heavy, [&] {
            const auto cancel = RequestCancel::for_current_request(app.config().limits);
            const std::string format =
                req.has_param("format") ? req.get_param_value("format") : "json";
            if (format != "json" && format != "markdown") {
                throw ApiError(ErrorCode::unsupported_format,
                               "format must be json or markdown, got \"" + format + "\"");
            }
            const Json body = parse_json(req.body);
            auto engine = cancel.guard(
                [&] { return app.models().build_stateless_scene(body, cancel.token()); });
            const engine::Ray ray = parse_single_ray(body, "/ray");
            const auto explained = engine::explain(engine->scene(), ray, cancel.token());
            const engine::Explanation& ex = cancel.check(explained);
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
