// GET /v1/health, GET /v1/info, GET /v1/openapi.json

#include <fstream>
#include <sstream>
#include <thread>

#include "engine/backend.h"
#include "server/app.h"
#include "server/openapi.h"
#include "server/schema/json_writer.h"

namespace raycastd::server {

namespace {

/// Resident set size of this process in bytes, from /proc/self/statm (0 where unavailable).
std::size_t resident_bytes() {
    std::ifstream f("/proc/self/statm");
    std::size_t pages_total = 0, pages_resident = 0;
    if (!(f >> pages_total >> pages_resident))
        return 0;
    return pages_resident * 4096;
}

}  // namespace

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
                  {"max_triangles", c.limits.max_triangles},
                  {"max_concurrent", app.max_concurrent()},
                  {"memory_budget_bytes", c.limits.memory_budget_bytes}}},
                {"requests_in_flight", app.requests_in_flight()},
                {"memory_resident_bytes", resident_bytes()},
            };
            app.add_registry_info(info);
            send_json(res, info.dump());
        });
    });
    app.on_get("/v1/openapi.json", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, Work::light, [&] { send_json(res, openapi_document()); });
    });
}

}  // namespace raycastd::server
