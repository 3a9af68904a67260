#include "server/app.h"

#include <cstdio>
#include <exception>
#include <fstream>
#include <sstream>
#include <thread>

#include "server/routes_web.h"
#include "server/schema/scene_doc.h"

namespace raycastd::server {

namespace {

int pick_worker_threads(const Config& c) {
    if (c.threads > 0)
        return c.threads;
    // cpp-httplib serves a keep-alive connection on one worker thread until the client goes
    // quiet for the keep-alive timeout, so the worker count is the number of clients served at
    // once: with 4 workers a fifth keep-alive client waited 30 s (measured). Idle workers
    // cost a stack each; the work itself is bounded by --max-concurrent and runs on TBB.
    return std::max(64, 8 * static_cast<int>(std::thread::hardware_concurrency()));
}

/// Work requests in flight before 503 busy: by default one per worker, so that no client is
/// turned away while a worker is free to serve it (each request runs on every core through
/// TBB, so more of them share the cores rather than queue). Operators bound memory with it.
std::size_t pick_max_concurrent(const Config& c, int threads) {
    if (c.limits.max_concurrent)
        return c.limits.max_concurrent;
    return static_cast<std::size_t>(threads);
}

/// Holds one concurrent-work slot for the life of a request.
class WorkSlot {
  public:
    WorkSlot(std::atomic<std::size_t>& counter, std::size_t limit) : counter_(counter) {
        if (counter_.fetch_add(1) >= limit) {
            counter_.fetch_sub(1);
            throw api_error("busy", "the server is at its limit of " + std::to_string(limit) +
                                        " concurrent requests; retry shortly");
        }
    }
    ~WorkSlot() { counter_.fetch_sub(1); }
    WorkSlot(const WorkSlot&) = delete;
    WorkSlot& operator=(const WorkSlot&) = delete;

  private:
    std::atomic<std::size_t>& counter_;
};

void send_error(httplib::Response& res, const ApiError& e) {
    send_json(res, error_body(e), e.http_status);
}

}  // namespace

void send_json(httplib::Response& res, std::string body, int status) {
    res.status = status;
    res.set_content(std::move(body), "application/json");
}

App::App(Config config) : config_(std::move(config)), scene_root_(config_.scene_root) {
    registry_ =
        std::make_unique<SceneRegistry>(config_.data_dir, config_.limits.memory_budget_bytes,
                                        [this](const SceneSource& src, const FileSource& files) {
                                            return build_scene(src, files);
                                        });
    const int threads = threads_ = pick_worker_threads(config_);
    max_concurrent_ = pick_max_concurrent(config_, threads);
    http_.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
    // Without TCP_NODELAY every small response waits for the delayed ACK (~40 ms): 530 instead
    // of 36,000 requests/s on this machine (PERFORMANCE.md).
    http_.set_tcp_nodelay(true);
    http_.set_keep_alive_max_count(100000);
    http_.set_keep_alive_timeout(30);
    http_.set_payload_max_length(config_.limits.max_body_bytes);
    http_.set_read_timeout(60, 0);
    http_.set_write_timeout(60, 0);

    http_.set_pre_routing_handler([this](const httplib::Request&, httplib::Response& res) {
        res.set_header("X-Request-Id", "rq_" + std::to_string(next_request_id_.fetch_add(1)));
        return httplib::Server::HandlerResponse::Unhandled;
    });
    // Errors raised by httplib itself (no route, body over the limit, ...) get the same JSON
    // shape as ours; responses we already filled in are left alone.
    http_.set_error_handler(httplib::Server::HandlerWithResponse([](const httplib::Request& req,
                                                                    httplib::Response& res) {
        if (!res.body.empty())
            return httplib::Server::HandlerResponse::Unhandled;
        if (res.status == 404) {
            send_error(res,
                       api_error("not_found", "no such endpoint: " + req.method + " " + req.path));
        } else if (res.status == 413) {
            send_error(res, api_error("too_large", "request body is over the configured limit"));
        } else if (res.status == 400) {
            send_error(res, api_error("invalid_request", "malformed HTTP request"));
        } else {
            send_json(res, error_body(ApiError("internal", res.status, "HTTP error")), res.status);
        }
        return httplib::Server::HandlerResponse::Handled;
    }));
    http_.set_exception_handler(
        [](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
            std::string what = "unknown exception";
            try {
                if (ep)
                    std::rethrow_exception(ep);
            } catch (const std::exception& e) {
                what = e.what();
            } catch (...) {
            }
            const std::string id = res.get_header_value("X-Request-Id");
            std::fprintf(stderr, "raycastd: internal error in %s %s [%s]: %s\n", req.method.c_str(),
                         req.path.c_str(), id.c_str(), what.c_str());
            send_error(res, api_error("internal", "internal error (request " + id + ")"));
        });
    if (config_.access_log) {
        http_.set_logger([](const httplib::Request& req, const httplib::Response& res) {
            std::fprintf(stderr, "%s %s %d %zu [%s]\n", req.method.c_str(), req.path.c_str(),
                         res.status, res.body.size(), res.get_header_value("X-Request-Id").c_str());
        });
    }
    install_routes();
}

App::~App() {
    stop();
}

void App::install_routes() {
    install_meta_routes(*this);
    install_query_routes(*this);
    install_trace_routes(*this);
    install_scene_routes(*this);
    install_render_routes(*this);
    install_web_routes(*this);
}

int App::bind() {
    if (config_.port == 0)
        return http_.bind_to_any_port(config_.host);
    return http_.bind_to_port(config_.host, config_.port) ? config_.port : -1;
}

bool App::listen_after_bind() {
    return http_.listen_after_bind();
}

void App::stop() {
    http_.stop();
}

void App::handle(const httplib::Request& req, httplib::Response& res, bool heavy,
                 const std::function<void()>& work) {
    try {
        if (heavy) {
            WorkSlot slot(in_flight_, max_concurrent_);
            work();
        } else {
            work();
        }
    } catch (const ApiError& e) {
        send_error(res, e);
    } catch (const std::bad_alloc&) {
        send_error(res, api_error("too_large", "out of memory while serving the request"));
    } catch (const std::exception& e) {
        const std::string id = res.get_header_value("X-Request-Id");
        std::fprintf(stderr, "raycastd: internal error in %s %s [%s]: %s\n", req.method.c_str(),
                     req.path.c_str(), id.c_str(), e.what());
        send_error(res, api_error("internal", "internal error (request " + id + ")"));
    }
}

std::shared_ptr<void> App::extend_work_slot() {
    in_flight_.fetch_add(1);
    return std::shared_ptr<void>(nullptr, [this](void*) { in_flight_.fetch_sub(1); });
}

Json App::parse_json_body(const httplib::Request& req) {
    if (req.body.empty())
        throw api_error("bad_json", "empty body: a JSON document is required");
    try {
        return Json::parse(req.body);
    } catch (const Json::parse_error& e) {
        throw api_error("bad_json",
                        "body is not valid JSON: byte " + std::to_string(e.byte) + ": " + e.what());
    } catch (const Json::exception& e) {
        // e.g. out_of_range.406 for 1e400: JSON cannot carry infinity.
        throw api_error("bad_json", std::string("body is not usable JSON: ") + e.what());
    }
}

}  // namespace raycastd::server

namespace raycastd::server {

namespace {

std::shared_ptr<const engine::QueryEngine> prepare(engine::Scene scene, const Limits& limits,
                                                   const std::string& prefix) {
    if (scene.triangle_count() > limits.max_triangles) {
        throw api_error("too_large",
                        "the scene has " + std::to_string(scene.triangle_count()) +
                            " triangles, over the limit of " + std::to_string(limits.max_triangles),
                        prefix);
    }
    auto built = engine::QueryEngine::build(std::make_shared<engine::Scene>(std::move(scene)));
    if (!built.ok())
        throw from_status(built.status(), prefix);
    return *built;
}

}  // namespace

std::shared_ptr<const engine::QueryEngine> App::build_stateless_scene(
    const Json& doc, const std::string& prefix) const {
    return stateless_cache_.get_or_build(doc, [&] {
        return prepare(scene_from_document(doc, prefix, scene_root_files(), config_.limits),
                       config_.limits, prefix);
    });
}

std::shared_ptr<const engine::QueryEngine> App::build_scene(const SceneSource& src,
                                                            const FileSource& files) const {
    if (src.content_type == "application/json") {
        Json doc;
        try {
            doc = Json::parse(src.body);
        } catch (const Json::parse_error& e) {
            throw api_error("bad_json", "body is not valid JSON: byte " + std::to_string(e.byte) +
                                            ": " + e.what());
        } catch (const Json::exception& e) {
            throw api_error("bad_json", std::string("body is not usable JSON: ") + e.what());
        }
        return prepare(scene_from_document(doc, "", files, config_.limits), config_.limits, "");
    }
    auto format = format_from_content_type(src.content_type);
    if (!format)
        throw api_error("unsupported_format", "cannot load " + src.content_type);
    return prepare(scene_from_model(src.body, *format, "model", config_.limits), config_.limits,
                   "");
}

FileSource App::scene_root_files() const {
    return [this](const std::string& path) {
        return scene_root_.read(path, config_.limits.max_body_bytes);
    };
}

ApiError App::scene_not_found(const std::string& id) {
    return api_error("scene_not_found", "no scene with id " + id);
}

std::shared_ptr<const engine::QueryEngine> App::scene_or_404(const std::string& id) {
    auto engine = registry_->get(id);
    if (!engine)
        throw scene_not_found(id);
    return engine;
}

std::string App::classify_scene_body(const httplib::Request& req) const {
    if (req.body.empty())
        throw api_error("bad_json", "empty body: a scene document or model file is required");
    std::string ct = req.get_header_value("Content-Type");
    ct = ct.substr(0, ct.find(';'));
    if (ct == "application/json")
        return ct;
    if (format_from_content_type(ct))
        return ct;
    if (!ct.empty() && ct != "application/octet-stream" &&
        ct != "application/x-www-form-urlencoded" && ct != "text/plain") {
        throw api_error("unsupported_format",
                        "Content-Type " + ct +
                            " is not a scene document (application/json) or a model type "
                            "(model/gltf-binary, model/gltf+json, model/obj, application/sla, "
                            "application/x-ply, model/off)");
    }
    // No usable type (curl -d sends form-urlencoded): tell by the bytes.
    if (auto f = engine::sniff_format(req.body)) {
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
    const auto first = req.body.find_first_not_of(" \t\r\n");
    if (first != std::string::npos && req.body[first] == '{') {
        // A glTF document has an "asset" object; a scene document has "objects".
        try {
            const Json j = Json::parse(req.body);
            if (j.is_object() && j.contains("asset") && !j.contains("objects"))
                return "model/gltf+json";
        } catch (const Json::exception&) {
        }
        return "application/json";
    }
    throw api_error("unsupported_format", "cannot tell what the body is; set Content-Type");
}

void App::add_registry_info(Json& info) const {
    info["scenes_registered"] = registry_->size();
    info["scenes_loaded"] = registry_->resident();
    info["scene_memory_bytes"] = registry_->resident_bytes();
    info["stateless_cache_hits"] = stateless_cache_.hits();
}

bool App::start(std::string& error) {
    if (!registry_->open(error))
        return false;
    for (const std::string& path : config_.demo) {
        std::ifstream f(path, std::ios::binary);
        if (!f) {
            error = "cannot read demo scene " + path;
            return false;
        }
        std::stringstream ss;
        ss << f.rdbuf();
        try {
            auto added =
                registry_->add(SceneSource{"application/json", ss.str()}, scene_root_files());
            std::fprintf(stderr, "raycastd: demo scene %s registered as %s\n", path.c_str(),
                         added.info.id.c_str());
        } catch (const std::exception& e) {
            error = "demo scene " + path + ": " + e.what();
            return false;
        }
    }
    return true;
}
}  // namespace raycastd::server
