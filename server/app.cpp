#include "server/app.h"

#include <algorithm>
#include <cassert>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <exception>
#include <fstream>
#include <sstream>
#include <thread>

#include "engine/process_memory.h"
#include "server/content_hash.h"
#include "server/request_cancel.h"
#include "server/request_log.h"
#include "server/routes_web.h"

namespace raycastd::server {

namespace {

/// Connections served at once: each holds a thread while it is being served, and a
/// connection between requests gives its thread up to a new one (server/http/connections.h),
/// so this bounds threads, not clients.
int pick_connections(const Config& c) {
    return c.threads > 0 ? c.threads : 512;
}

/// Work requests in flight before 503 busy. Each request runs on every core through TBB, so
/// more of them share the cores rather than queue; operators bound memory with it.
std::size_t pick_max_concurrent(const Config& c) {
    if (c.limits.max_concurrent)
        return c.limits.max_concurrent;
    return static_cast<std::size_t>(
        std::max(64, 8 * static_cast<int>(std::thread::hardware_concurrency())));
}

ConnectionLimits connection_limits(const Config& c) {
    ConnectionLimits l;
    l.max_connections = static_cast<std::size_t>(pick_connections(c));
    l.header_timeout = std::chrono::seconds(c.limits.header_timeout_s);
    l.idle_timeout = std::chrono::seconds(c.limits.idle_timeout_s);
    l.body_budget_bytes = c.limits.body_budget_bytes;
    l.head.max_body_bytes = c.limits.max_body_bytes;
    return l;
}

/// Holds one concurrent-work slot for the life of a request.
class WorkSlot {
  public:
    WorkSlot(std::atomic<std::size_t>& counter, std::size_t limit) : counter_(counter) {
        if (counter_.fetch_add(1) >= limit) {
            counter_.fetch_sub(1);
            throw ApiError(ErrorCode::busy, "the server is at its limit of " +
                                                std::to_string(limit) +
                                                " concurrent requests; retry shortly");
        }
    }
    ~WorkSlot() { counter_.fetch_sub(1); }
    WorkSlot(const WorkSlot&) = delete;
    WorkSlot& operator=(const WorkSlot&) = delete;

  private:
    std::atomic<std::size_t>& counter_;
};

/// Busy and timeout answers by a reason of their own, as an operator alerts on them.
void add_reason_headers(httplib::Response& res, const ApiError& e) {
    if (e.code == ErrorCode::unauthorized)
        res.set_header("WWW-Authenticate", "Bearer");
    // A busy server is over a momentary limit: a second is what a request takes here.
    if (e.code == ErrorCode::busy)
        res.set_header("Retry-After", "1");
}

/// An X-Request-Id a client may choose: 1 to 128 letters, digits and "._:-" (it is echoed in
/// a header and written into log lines, so nothing else).
bool is_request_id(const std::string& id) {
    return !id.empty() && id.size() <= 128 && std::all_of(id.begin(), id.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == ':' ||
               c == '-';
    });
}

/// The id group of our route patterns, and the rest-of-the-path group (static files): the only
/// regexes in them.
constexpr std::string_view kIdGroup = "([A-Za-z0-9_]+)";
constexpr std::string_view kRestGroup = "(.*)";

bool is_id_char(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
}

/// Whether `path` matches a route pattern as cpp-httplib's std::regex_match would, for
/// patterns of literal text and kIdGroup (std::regex itself is avoided here: GCC 12 warns
/// inside it under the sanitizers). An id takes every id character: in our patterns it is
/// followed by '/' or the end.
bool matches_route(std::string_view pattern, std::string_view path) {
    while (!pattern.empty()) {
        if (pattern == kRestGroup)
            return true;
        if (pattern.substr(0, kIdGroup.size()) == kIdGroup) {
            pattern.remove_prefix(kIdGroup.size());
            std::size_t n = 0;
            while (n < path.size() && is_id_char(path[n]))
                ++n;
            if (n == 0)
                return false;
            path.remove_prefix(n);
        } else if (!path.empty() && path.front() == pattern.front()) {
            pattern.remove_prefix(1);
            path.remove_prefix(1);
        } else {
            return false;
        }
    }
    return path.empty();
}

/// A pattern matches_route() reads as cpp-httplib does: no regex but kIdGroup ('.' is taken
/// literally; "/v1/openapi.json" is the one path with it).
[[maybe_unused]] bool is_plain_route(std::string_view pattern) {
    constexpr std::string_view kRegexChars = "()[]{}*+?|^$\\";
    while (!pattern.empty()) {
        if (pattern == kRestGroup)
            return true;
        if (pattern.substr(0, kIdGroup.size()) == kIdGroup) {
            pattern.remove_prefix(kIdGroup.size());
        } else if (kRegexChars.find(pattern.front()) != std::string_view::npos) {
            return false;
        } else {
            pattern.remove_prefix(1);
        }
    }
    return true;
}

/// The methods an Allow header names, in this order; a GET route answers HEAD too.
constexpr const char* kMethods[] = {"GET", "HEAD", "POST", "DELETE"};

/// Whether an Allow list ("GET, HEAD") names `method`.
bool lists_method(const std::string& allow, const std::string& method) {
    std::size_t begin = 0;
    while (begin < allow.size()) {
        const std::size_t end = std::min(allow.find(", ", begin), allow.size());
        if (allow.compare(begin, end - begin, method) == 0)
            return true;
        begin = end + 2;
    }
    return false;
}

}  // namespace

void App::send_error(httplib::Response& res, const ApiError& e) {
    metrics_.count_error(e.code);
    add_reason_headers(res, e);
    send_json(res, error_body(e), e.http_status());
}

void App::send_internal(const httplib::Request& req, httplib::Response& res, const char* what) {
    const std::string id = res.get_header_value("X-Request-Id");
    // Always logged: error is the lowest --log-level.
    const std::string line = message_log_line(
        LogLevel::error, "internal error in " + req.method + " " + req.path + ": " + what, id);
    std::fprintf(stderr, "%s\n", line.c_str());
    send_error(res, ApiError(ErrorCode::internal, "internal error (request " + id + ")"));
}

void send_json(httplib::Response& res, std::string body, int status) {
    res.status = status;
    res.set_content(std::move(body), "application/json");
}

App::App(Config config)
    : config_(std::move(config)),
      answers_(config_.limits.answer_budget_bytes),
      http_(connection_limits(config_)),
      models_(config_.limits, config_.scene_root) {
    registry_ = std::make_unique<SceneRegistry>(
        config_.data_dir, config_.limits.memory_budget_bytes,
        [this](const SceneSource& src, const FileSource& files) {
            const auto t0 = std::chrono::steady_clock::now();
            auto engine = models_.build_scene(src, files);
            metrics_.observe_scene_build(
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
            return engine;
        });
    threads_ = pick_connections(config_);
    max_concurrent_ = pick_max_concurrent(config_);
    // Connections, deadlines, keep-alive and framing are HttpServer's (server/http/); a body's
    // length, decoded and chunked ones included, is read_body()'s to bound (the library checks
    // only a Content-Length against this, and HttpServer checks that first).
    http_.set_payload_max_length(config_.limits.max_body_bytes);
    install_handlers();
    install_routes();
    add_gauges();
}

App::~App() {
    stop();
}

void App::install_handlers() {
    http_.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
        // A balancer's id (nginx's $request_id, deploy/nginx.conf) is adopted, so that its log
        // and ours name the same request; one that is not a plain token gets ours.
        const std::string given = req.get_header_value("X-Request-Id");
        res.set_header("X-Request-Id", is_request_id(given) ? given : http_.next_request_id());
        // The request is timed from here (its head has been read) to its logger call.
        RequestRecord& r = current_request();
        r = RequestRecord{};
        r.open = true;
        r.start = std::chrono::steady_clock::now();
        r.metrics = &metrics_;
        // cpp-httplib reads the body of a request no route of ours takes (inflating it without
        // limit) before it answers 404: such a request is answered here, its body unread, as
        // every body is read by a route of ours through read_body(). The methods are those it
        // reads a body for.
        const bool has_body = req.method == "POST" || req.method == "PUT" ||
                              req.method == "PATCH" || req.method == "DELETE" ||
                              req.method == "PRI";
        if (has_body && !lists_method(allowed_methods(req.path), req.method)) {
            res.status = 404;
            answer_http_error(req, res);
            return httplib::Server::HandlerResponse::Handled;
        }
        return httplib::Server::HandlerResponse::Unhandled;
    });
    // Errors raised by httplib itself (no route, body over the limit, ...) get the same JSON
    // shape as ours; responses we already filled in are left alone.
    http_.set_error_handler(httplib::Server::HandlerWithResponse(
        [this](const httplib::Request& req, httplib::Response& res) {
            return answer_http_error(req, res) ? httplib::Server::HandlerResponse::Handled
                                               : httplib::Server::HandlerResponse::Unhandled;
        }));
    http_.set_exception_handler(
        [this](const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
            std::string what = "unknown exception";
            try {
                if (ep)
                    std::rethrow_exception(ep);
            } catch (const std::exception& e) {
                what = e.what();
            } catch (...) {
            }
            send_internal(req, res, what.c_str());
        });
    // cpp-httplib calls its logger on the serving thread once the answer has been written,
    // streamed answers included.
    http_.set_logger([this](const httplib::Request& req, const httplib::Response& res) {
        close_request(req, res);
    });
}

void App::close_request(const httplib::Request& req, const httplib::Response& res) {
    RequestRecord& r = current_request();
    // A request httplib could not read (a bad request line) never reached the pre-routing
    // handler: it has no start time and is counted as unmatched, in no time.
    const double seconds =
        r.open ? std::chrono::duration<double>(std::chrono::steady_clock::now() - r.start).count()
               : 0.0;
    // Route 0 until a handler names its own: no route matched, counted by method.
    const std::size_t route =
        r.open && r.route != 0 ? r.route : metrics_.unmatched_route(r.open ? req.method : "");
    metrics_.observe_request(route, res.status, seconds);
    if (logs_request(config_.log_level, res.status)) {
        RequestLogEntry e;
        const std::string id = res.get_header_value("X-Request-Id");
        e.request_id = id;
        e.method = req.method;
        e.route = metrics_.route_name(route);
        e.path = req.path;
        e.status = res.status;
        e.duration_ms = seconds * 1e3;
        e.rays = r.open ? r.rays : 0;
        e.request_bytes = req.body.size();
        e.response_bytes = res.content_length_ > 0 ? res.content_length_ : res.body.size();
        const std::string line = request_log_line(e, config_.log_level);
        std::fprintf(stderr, "%s\n", line.c_str());
    }
    r = RequestRecord{};
}

void App::add_gauges() {
    // Read at scrape time from the figures their owners keep (each behind its own lock or an
    // atomic); none is touched by the request path for the sake of /metrics.
    metrics_.add_gauge("raycastd_scenes_registered", "gauge",
                       "Scenes this replica knows (in memory or saved in the data dir).",
                       [this] { return static_cast<double>(registry_->size()); });
    metrics_.add_gauge("raycastd_scenes_loaded", "gauge",
                       "Scenes prepared in memory (the rest reload on demand).",
                       [this] { return static_cast<double>(registry_->resident()); });
    metrics_.add_gauge("raycastd_scene_memory_bytes", "gauge",
                       "Estimated memory of the prepared scenes (--memory-budget-mb bounds it).",
                       [this] { return static_cast<double>(registry_->resident_bytes()); });
    metrics_.add_gauge("process_resident_memory_bytes", "gauge",
                       "Resident set size of the process (/proc/self/statm).",
                       [] { return static_cast<double>(engine::process_resident_bytes()); });
    metrics_.add_gauge("raycastd_answer_bytes", "gauge",
                       "Bytes of answers being built or written (--answer-budget-mb bounds it).",
                       [this] { return static_cast<double>(answers_.used()); });
    metrics_.add_gauge("raycastd_answer_budget_bytes", "gauge",
                       "The answers' budget (--answer-budget-mb); one answer alone may exceed it.",
                       [this] { return static_cast<double>(answers_.limit()); });
    metrics_.add_gauge("raycastd_body_bytes", "gauge",
                       "Bytes of request bodies being received or served (by Content-Length).",
                       [this] { return static_cast<double>(http_.stats().body_bytes_in_flight); });
    metrics_.add_gauge("raycastd_body_budget_bytes", "gauge",
                       "The request bodies' budget (--body-budget-mb).",
                       [this] { return static_cast<double>(config_.limits.body_budget_bytes); });
    metrics_.add_gauge("raycastd_requests_in_flight", "gauge",
                       "Work requests holding a --max-concurrent slot.",
                       [this] { return static_cast<double>(in_flight_.load()); });
    metrics_.add_gauge("raycastd_connections_open", "gauge", "Client connections open.",
                       [this] { return static_cast<double>(http_.stats().open_connections); });
    metrics_.add_gauge("raycastd_busy_rejections_total", "counter",
                       "Requests refused 503 busy: over --max-concurrent, the render queue, "
                       "--body-budget-mb or --answer-budget-mb.",
                       [this] {
                           return static_cast<double>(metrics_.errors(ErrorCode::busy) +
                                                      http_.stats().busy_bodies);
                       });
    metrics_.add_gauge("raycastd_request_timeouts_total", "counter",
                       "Work stopped at --request-timeout-s (503 timeout).",
                       [this] { return static_cast<double>(metrics_.errors(ErrorCode::timeout)); });
    metrics_.add_gauge("raycastd_connection_timeouts_total", "counter",
                       "Connections dropped at a deadline (slow head or body).",
                       [this] { return static_cast<double>(http_.stats().timeouts); });
    metrics_.add_gauge("raycastd_refused_heads_total", "counter",
                       "Malformed or oversized request heads answered by the connection layer.",
                       [this] { return static_cast<double>(http_.stats().refused_heads); });
}

bool App::answer_http_error(const httplib::Request& req, httplib::Response& res) {
    if (!res.body.empty())
        return false;
    // No route for this method (404), or a method httplib routes nowhere (400: TRACE): 405 if
    // the path is one of ours.
    if (res.status == 404 || res.status == 400) {
        const std::string allow = allowed_methods(req.path);
        if (!allow.empty() && !lists_method(allow, req.method)) {
            res.set_header("Allow", allow);
            send_error(
                res, ApiError(ErrorCode::method_not_allowed, req.method + " is not allowed on " +
                                                                 req.path + "; allowed: " + allow));
            return true;
        }
    }
    if (res.status == 404) {
        send_error(res, ApiError(ErrorCode::not_found,
                                 "no such endpoint: " + req.method + " " + req.path));
    } else if (res.status == 413) {
        send_error(res,
                   ApiError(ErrorCode::too_large, "request body is over the configured limit"));
    } else if (res.status == 400) {
        send_error(res, ApiError(ErrorCode::invalid_request, "malformed HTTP request"));
    } else if (res.status == 414) {
        // The contract's one exception to the table: a URL over the limit is too_large with
        // the status that names a URL (cpp-httplib refuses request lines over 8,192 bytes).
        metrics_.count_error(ErrorCode::too_large);
        send_json(res,
                  error_body(ApiError(ErrorCode::too_large,
                                      "the request line is over the limit of 8,192 bytes")),
                  414);
    } else {
        // httplib's own status (416 bad range, ...) is kept.
        metrics_.count_error(ErrorCode::internal);
        send_json(res, error_body(ApiError(ErrorCode::internal, "HTTP error")), res.status);
    }
    return true;
}

void App::install_routes() {
    install_meta_routes(*this);
    install_intersect_routes(*this);
    install_trace_routes(*this);
    install_scene_routes(*this);
    install_render_routes(*this);
    install_points_routes(*this);
    install_web_routes(*this);
}

std::size_t App::remember(const std::string& pattern, const char* method) {
    assert(is_plain_route(pattern));
    routes_.push_back({pattern, method});
    return metrics_.add_route(method, pattern);
}

namespace {

/// `handler`, naming its route in the request's record first (for the metrics and log line).
template <typename Handler>
Handler named_route(std::size_t route, Handler handler) {
    return [route, handler = std::move(handler)](auto&&... args) {
        current_request().route = route;
        return handler(std::forward<decltype(args)>(args)...);
    };
}

}  // namespace

void App::on_get(const std::string& pattern, httplib::Server::Handler handler) {
    http_.Get(pattern, named_route(remember(pattern, "GET"), std::move(handler)));
}

httplib::Server::HandlerWithContentReader App::reading_body(httplib::Server::Handler handler) {
    // A content-reader route, not a plain one: cpp-httplib reads a plain route's body before
    // calling it, inflating a Content-Encoding without limit, and before its token is checked.
    return [this, handler = std::move(handler)](const httplib::Request& req, httplib::Response& res,
                                                const httplib::ContentReader& read) {
        try {
            // The request is process_request's own (non-const) object, handed to a content
            // reader as const: its body is filled in as the library's reader would have.
            std::string& body = const_cast<httplib::Request&>(req).body;
            if (!read_body(req, read, [&body](const char* data, std::size_t len) {
                    body.append(data, len);
                    return true;
                }))
                throw body_cut_off();
        } catch (const ApiError& e) {
            send_error(res, e);
            return;
        }
        handler(req, res);
    };
}

httplib::Server::HandlerWithContentReader App::guarded(
    httplib::Server::HandlerWithContentReader handler, Access access) {
    if (access == Access::open)
        return handler;
    return [this, handler = std::move(handler)](const httplib::Request& req, httplib::Response& res,
                                                const httplib::ContentReader& read) {
        try {
            require_write_token(req);  // before a byte of the body is read
        } catch (const ApiError& e) {
            send_error(res, e);
            return;
        }
        handler(req, res, read);
    };
}

void App::on_post(const std::string& pattern, httplib::Server::Handler handler, Access access) {
    on_post(pattern, reading_body(std::move(handler)), access);
}

void App::on_post(const std::string& pattern, httplib::Server::HandlerWithContentReader handler,
                  Access access) {
    http_.Post(pattern,
               named_route(remember(pattern, "POST"), guarded(std::move(handler), access)));
}

void App::on_delete(const std::string& pattern, httplib::Server::Handler handler, Access access) {
    http_.Delete(pattern, named_route(remember(pattern, "DELETE"),
                                      guarded(reading_body(std::move(handler)), access)));
}

bool App::read_body(const httplib::Request& req, const httplib::ContentReader& read,
                    const std::function<bool(const char*, std::size_t)>& receiver) const {
    // cpp-httplib would hand a multipart body to a multipart receiver, which no route has.
    if (req.is_multipart_form_data()) {
        throw ApiError(ErrorCode::unsupported_format,
                       "a multipart/form-data body is not read: send the document or file "
                       "itself as the body");
    }
    // Neither a Content-Length nor chunked framing (the only Transfer-Encoding the connection
    // layer lets through, request_head.cpp): RFC 9112 §6.3 gives a request body length 0.
    // cpp-httplib would read to the end of the connection instead, so that `curl -X POST` with
    // no data waited out the body's grace period for a 400, and a request sent after it on the
    // connection was swallowed as its body (a helper's review).
    if (!req.has_header("Content-Length") && !req.has_header("Transfer-Encoding"))
        return true;
    const std::uint64_t limit = config_.limits.max_body_bytes;
    MemoryBudget::Lease& lease = HttpServer::body_lease();
    enum class Stop { none, too_large, busy, refused };
    Stop stop = Stop::none;
    std::uint64_t got = 0;
    const bool ok = read([&](const char* data, std::size_t len) {
        // Counted as decoded: a 200 KB gzip body may inflate to 200 MB, and what it inflates to
        // is what is held. Refusing stops the library's decompressor and its reading at once.
        got += len;
        if (got > limit) {
            stop = Stop::too_large;
            return false;
        }
        // The connection layer charged the Content-Length before the body was read; bytes past
        // it (decoded, or a chunked body, which has none) are charged as they come.
        if (got > lease.bytes()) {
            const std::uint64_t step =
                std::min(limit, (got + kBodyChargeStep - 1) / kBodyChargeStep * kBodyChargeStep);
            if (!lease.bound() || !lease.resize(step)) {
                stop = Stop::busy;
                return false;
            }
        }
        if (!receiver(data, len)) {
            stop = Stop::refused;
            return false;
        }
        return true;
    });
    switch (stop) {
        case Stop::too_large:
            throw ApiError(ErrorCode::too_large,
                           "request body is over the configured limit of " + std::to_string(limit) +
                               " bytes" +
                               (req.has_header("Content-Encoding") ? " once decoded" : ""));
        case Stop::busy:
            throw ApiError(ErrorCode::busy,
                           "request bodies in flight are at the server's limit of " +
                               std::to_string(config_.limits.body_budget_bytes >> 20) +
                               " MiB (--body-budget-mb); retry shortly");
        case Stop::refused:
            return false;
        case Stop::none:
            break;
    }
    return ok;
}

ApiError App::body_cut_off() {
    return ApiError(ErrorCode::invalid_request,
                    "the request body ended before the end its Content-Length or chunked framing "
                    "gives, or its Content-Encoding cannot be decoded");
}

std::string App::allowed_methods(const std::string& path) const {
    bool allowed[std::size(kMethods)] = {};
    for (const Route& r : routes_) {
        if (!matches_route(r.pattern, path))
            continue;
        for (std::size_t m = 0; m < std::size(kMethods); ++m) {
            const std::string_view method = kMethods[m];
            if (method == r.method || (method == "HEAD" && std::string_view(r.method) == "GET"))
                allowed[m] = true;
        }
    }
    std::string out;
    for (std::size_t m = 0; m < std::size(kMethods); ++m) {
        if (allowed[m])
            out += (out.empty() ? "" : ", ") + std::string(kMethods[m]);
    }
    return out;
}

int App::bind() {
    return http_.bind(config_.host, config_.port);
}

bool App::listen_after_bind() {
    return http_.listen_after_bind();
}

void App::stop() {
    http_.stop();
}

void App::handle(const httplib::Request& req, httplib::Response& res, Work cost,
                 const std::function<void()>& work) {
    try {
        if (cost == Work::heavy) {
            WorkSlot slot(in_flight_, max_concurrent_);
            work();
        } else {
            work();
        }
    } catch (const ApiError& e) {
        send_error(res, e);
    } catch (const ClientGone&) {
        // Nobody is there to read an answer (request_cancel.h): none is written.
        HttpServer::current_client().hang_up();
    } catch (const std::bad_alloc&) {
        send_error(res, ApiError(ErrorCode::too_large, "out of memory while serving the request"));
    } catch (const std::exception& e) {
        send_internal(req, res, e.what());
    }
    charge_written_answer(res);
}

void App::charge_answer(std::uint64_t bytes) {
    MemoryBudget::Lease& lease = HttpServer::answer_lease();
    if (bytes < kSmallAnswerBytes) {
        lease.release();
        return;
    }
    if (!lease.bound())
        lease = answers_.empty_lease();
    if (!lease.resize(bytes)) {
        throw ApiError(ErrorCode::busy, "answers in flight are at the server's limit of " +
                                            std::to_string(answers_.limit() >> 20) +
                                            " MiB (--answer-budget-mb); retry shortly");
    }
}

void App::charge_written_answer(httplib::Response& res) {
    // A streamed answer (a content provider) keeps the charge its route made for it.
    if (res.content_provider_)
        return;
    const std::uint64_t bytes = res.body.size();
    if (bytes < kSmallAnswerBytes && HttpServer::answer_lease().bytes() == 0)
        return;
    try {
        charge_answer(bytes);
    } catch (const ApiError& e) {
        // The work is done, but holding its answer while a slow client reads it would take the
        // budget over: it is dropped (the assignment frees it) for the error.
        send_error(res, e);
    }
}

std::shared_ptr<void> App::extend_work_slot() {
    in_flight_.fetch_add(1);
    return std::shared_ptr<void>(nullptr, [this](void*) { in_flight_.fetch_sub(1); });
}

void App::require_write_token(const httplib::Request& req) const {
    if (config_.token.empty())
        return;
    const std::string header = req.get_header_value("Authorization");
    constexpr std::string_view kScheme = "Bearer ";
    const bool bearer =
        header.size() > kScheme.size() &&
        std::equal(kScheme.begin(), kScheme.end(), header.begin(), [](char a, char b) {
            return std::tolower(static_cast<unsigned char>(a)) ==
                   std::tolower(static_cast<unsigned char>(b));
        });
    // Compared as SHA-256 digests with CRYPTO_memcmp: the time taken says nothing of how much
    // of the token, or of its length, a guess got right.
    const std::string given = bearer ? header.substr(kScheme.size()) : std::string();
    if (!bearer || !same_secret(given, config_.token)) {
        throw ApiError(ErrorCode::unauthorized,
                       bearer ? "the bearer token is not this server's"
                              : "this server takes writes only with Authorization: Bearer <token>");
    }
}

ApiError App::scene_not_found(const std::string& id) {
    return ApiError(ErrorCode::scene_not_found, "no scene with id " + id);
}

std::shared_ptr<const engine::QueryEngine> App::scene_or_404(const std::string& id) {
    auto engine = registry_->get(id);
    if (!engine)
        throw scene_not_found(id);
    return engine;
}

void App::add_registry_info(Json& info) const {
    info["scenes_registered"] = registry_->size();
    info["scenes_loaded"] = registry_->resident();
    info["scene_memory_bytes"] = registry_->resident_bytes();
    info["stateless_cache_hits"] = models_.stateless_cache_hits();
}

bool App::start(std::string& error) {
    if (!reserve_descriptors(static_cast<std::size_t>(threads_), error))
        return false;
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
            auto added = registry_->add(SceneSource{"application/json", ss.str()},
                                        models_.scene_root_files());
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
