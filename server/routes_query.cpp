// POST /v1/intersect (stateless) and, with the registry, POST /v1/scenes/{id}/intersect.

#include "engine/query/intersect.h"
#include "server/app.h"
#include "server/schema/query_doc.h"
#include "server/schema/scene_doc.h"

namespace raycastd::server {

void answer_intersect(const engine::QueryEngine& engine, const Json& body,
                      const std::string& prefix, std::size_t max_rays, httplib::Response& res) {
    IntersectRequest req = parse_intersect_request(body, prefix, max_rays);
    engine::QueryResult result = engine.intersect(req.rays, req.options);
    send_json(res, write_intersect_response(engine.scene(), req, result));
}

void install_query_routes(App& app) {
    app.http().Post("/v1/intersect", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, true, [&] {
            const Json body = App::parse_json_body(req);
            require_object(body, "", "invalid_request");
            const Json* scene_doc = member(body, "scene");
            if (!scene_doc) throw api_error("invalid_request", "/scene is required", "/scene");
            auto engine = app.build_stateless_scene(*scene_doc, "/scene");
            answer_intersect(*engine, body, "", app.config().limits.max_rays, res);
        });
    });
}

}  // namespace raycastd::server
