// GET /v1/health, GET /v1/info, GET /v1/openapi.json, GET /metrics

#include <thread>

#include "engine/backend.h"
#include "engine/process_memory.h"
#include "server/app.h"
#include "server/openapi.h"
#include "server/schema/json_writer.h"

namespace raycastd::server {

void install_meta_routes(App& app) {
    app.on_get("/v1/health", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, Work::light, [&] { send_json(res, R"({"status":"ok"})"); });
    });
    app.on_get("/v1/info", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, Work::light, [&] {
            const Config& c = app.config();
            Json info = {
                {"name", "raycastd"},
                {"version", RAYCASTD_VERSION},
                {"embree_version", engine::backend_version()},
                {"hardware_threads", std::thread::hardware_concurrency()},
                {"worker_threads", app.worker_threads()},
                {"limits",
                 {{"max_body_bytes", c.limits.max_body_bytes},
                  {"max_rays", c.limits.max_rays},
                  {"max_points", c.limits.max_points},
                  {"max_pixels", c.limits.max_pixels},
                  {"max_texture_pixels", c.limits.max_texture_pixels},
                  {"max_triangles", c.limits.max_triangles},
                  {"max_concurrent", app.max_concurrent()},
                  {"memory_budget_bytes", c.limits.memory_budget_bytes},
                  {"body_budget_bytes", c.limits.body_budget_bytes},
                  {"answer_budget_bytes", c.limits.answer_budget_bytes},
                  {"job_budget_bytes", c.limits.job_budget_bytes}}},
                {"requests_in_flight", app.requests_in_flight()},
                {"memory_resident_bytes", engine::process_resident_bytes()},
            };
            app.add_registry_info(info);
            send_json(res, info.dump());
        });
    });
    // Prometheus' scrape (server/metrics.h); light work, so a server at its limit still says so.
    app.on_get("/metrics", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, Work::light, [&] {
            res.status = 200;
            res.set_content(app.metrics_text(), Metrics::kContentType);
        });
    });
    app.on_get("/v1/openapi.json", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, Work::light, [&] { send_json(res, openapi_document()); });
    });
}

}  // namespace raycastd::server
