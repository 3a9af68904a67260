#include "server/app.h"

#include <cstdio>
#include <exception>
#include <fstream>
#include <sstream>
#include <thread>

#include "server/schema/scene_doc.h"

namespace raycastd::server {

namespace {

int pick_worker_threads(const Config& c) {
    if (c.threads > 0) return c.threads;
    // At least 4 so that slow clients on keep-alive connections cannot starve the others.
    return std::max(4, static_cast<int>(std::thread::hardware_concurrency()));
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

App::App(Config config) : config_(std::move(config)) {
    const int threads = threads_ = pick_worker_threads(config_);
    max_concurrent_ = config_.limits.max_concurrent ? config_.limits.max_concurrent
                                                    : static_cast<std::size_t>(2 * threads);
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
        if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
        if (res.status == 404) {
            send_error(res, api_error("not_found", "no such endpoint: " + req.method + " " +
                                                       req.path));
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
                if (ep) std::rethrow_exception(ep);
            } catch (const std::exception& e) {
                what = e.what();
            } catch (...) {
            }
            const std::string id = res.get_header_value("X-Request-Id");
            std::fprintf(stderr, "raycastd: internal error in %s %s [%s]: %s\n",
                         req.method.c_str(), req.path.c_str(), id.c_str(), what.c_str());
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

App::~App() { stop(); }

void App::install_routes() {
    install_meta_routes(*this);
    install_query_routes(*this);
    install_trace_routes(*this);
}

int App::bind() {
    if (config_.port == 0) return http_.bind_to_any_port(config_.host);
    return http_.bind_to_port(config_.host, config_.port) ? config_.port : -1;
}

bool App::listen_after_bind() { return http_.listen_after_bind(); }

void App::stop() {
    if (http_.is_running()) http_.stop();
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

Json App::parse_json_body(const httplib::Request& req) {
    if (req.body.empty()) throw api_error("bad_json", "empty body: a JSON document is required");
    try {
        return Json::parse(req.body);
    } catch (const Json::parse_error& e) {
        throw api_error("bad_json", "body is not valid JSON: byte " + std::to_string(e.byte) +
                                        ": " + e.what());
    } catch (const Json::exception& e) {
        // e.g. out_of_range.406 for 1e400: JSON cannot carry infinity.
        throw api_error("bad_json", std::string("body is not usable JSON: ") + e.what());
    }
}

}  // namespace raycastd::server

namespace raycastd::server {

std::shared_ptr<const engine::QueryEngine> App::build_stateless_scene(const Json& doc,
                                                                       const std::string& prefix) {
    auto scene = std::make_shared<engine::Scene>(parse_scene_doc(doc, prefix, {}));
    if (scene->triangle_count() > config_.limits.max_triangles) {
        throw api_error("too_large", "the scene has " + std::to_string(scene->triangle_count()) +
                                         " triangles, over the limit of " +
                                         std::to_string(config_.limits.max_triangles),
                        prefix);
    }
    auto built = engine::QueryEngine::build(std::move(scene));
    if (!built.ok()) throw from_status(built.status(), prefix);
    return *built;
}

void App::add_registry_info(Json& info) const { info["scenes_loaded"] = 0; }

bool App::start(std::string& error) {
    for (const std::string& path : config_.demo) {
        std::ifstream f(path, std::ios::binary);
        if (!f) {
            error = "cannot read demo scene " + path;
            return false;
        }
        std::stringstream ss;
        ss << f.rdbuf();
        try {
            build_stateless_scene(Json::parse(ss.str()), "");
        } catch (const std::exception& e) {
            error = "demo scene " + path + ": " + e.what();
            return false;
        }
    }
    return true;
}

}  // namespace raycastd::server
