#pragma once
// App: the HTTP front of raycastd. Builds the httplib::Server (routes, error and exception
// handlers, request ids, limits) over the engine; owns the scene registry and the model source
// that builds scenes. Routes are installed through on_get/on_post/on_delete, so that a known
// path asked with another method is answered 405 with the methods it has.

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <httplib.h>

#include "server/api_error.h"
#include "server/config.h"
#include "server/http/http_server.h"
#include "server/memory_budget.h"
#include "server/metrics.h"
#include "server/model_source.h"
#include "server/scene_registry.h"
#include "server/schema/json_read.h"

namespace raycastd::server {

/// What a request costs. `heavy` work (queries, renders, scene builds) takes one of the
/// --max-concurrent work slots, and is 503 busy when none is free; `light` work (lookups,
/// health, info) takes none.
enum class Work { light, heavy };

/// Who may call a route: anyone, or (when the server has a --token) only a request with its
/// bearer token, which is checked before a byte of the body is read.
enum class Access { open, write_token };

class App {
  public:
    explicit App(Config config);
    ~App();
    App(const App&) = delete;
    App& operator=(const App&) = delete;

    /// Start-up work before binding: registers the --demo scenes. False (with `error`) when
    /// one cannot be registered.
    bool start(std::string& error);

    /// Binds to config().host and config().port (0: any free port); returns the port or -1.
    int bind();
    /// Serves until stop(); returns false if the server could not run.
    bool listen_after_bind();
    void stop();

    const Config& config() const { return config_; }

    /// Installs a route. The pattern is cpp-httplib's (a regex over the path, groups read
    /// through req.matches), limited to literal text, `([A-Za-z0-9_]+)` for an id and a final
    /// `(.*)`, which is all our paths need and all allowed_methods() reads. GET routes answer HEAD
    /// too.
    void on_get(const std::string& pattern, httplib::Server::Handler handler);
    /// A POST route; its body is in req.body, read by read_body() (up to --max-body-mb, decoded)
    /// after the access check.
    void on_post(const std::string& pattern, httplib::Server::Handler handler,
                 Access access = Access::open);
    /// A POST route that reads its body itself, through read_body() (streamed into pooled
    /// buffers); called after the access check.
    void on_post(const std::string& pattern, httplib::Server::HandlerWithContentReader handler,
                 Access access = Access::open);
    /// A DELETE route; a body, if any, is read as on_post's.
    void on_delete(const std::string& pattern, httplib::Server::Handler handler,
                   Access access = Access::open);
    /// Reads the request's body through `read` into `receiver` as it comes out of any
    /// Content-Encoding (cpp-httplib inflates gzip, deflate and br): too_large as soon as the
    /// decoded bytes pass --max-body-mb (nothing more is read or inflated), busy when bytes past
    /// the head's Content-Length (decoded, or chunked) take --body-budget-mb over. True once the
    /// body has been read to the end its framing gives; false when it was cut off (the client
    /// stopped short of its Content-Length or last chunk) or cannot be decoded, or `receiver`
    /// refused bytes: body_cut_off() is the error for the first two.
    bool read_body(const httplib::Request& req, const httplib::ContentReader& read,
                   const std::function<bool(const char*, std::size_t)>& receiver) const;
    static ApiError body_cut_off();
    /// Decoded or chunked bodies are charged to the body budget this many bytes at a time.
    static constexpr std::uint64_t kBodyChargeStep = 1u << 20;
    /// The methods the routes serve for `path`, as an Allow header lists them ("GET, HEAD");
    /// empty when no route matches the path.
    std::string allowed_methods(const std::string& path) const;

    /// Runs `work` and turns what it throws into the API's JSON error responses; heavy work
    /// holds a work slot while it runs. Then the answer's body, when it is at least
    /// kSmallAnswerBytes or a charge was made for it, is charged to the answer budget at its
    /// exact size; an answer that does not fit is dropped and answered 503 busy instead.
    void handle(const httplib::Request& req, httplib::Response& res, Work cost,
                const std::function<void()>& work);

    /// Answers smaller than this are never charged nor refused: health, info, lookups and
    /// small queries are always answered, and cost no shared atomic.
    static constexpr std::uint64_t kSmallAnswerBytes = 64u << 10;
    /// What a JSON answer is charged per ray or point before the work, until its exact size is
    /// known: a closest hit with every field is ~250 bytes of JSON, a miss 15.
    static constexpr std::uint64_t kJsonBytesPerItem = 256;
    /// Inside work: the answer of the request served on this thread will hold `bytes` (an
    /// estimate before the work, or its exact size), charged to --answer-budget-mb until the
    /// answer has been written. Throws 503 busy when growing the charge would take the budget
    /// over its limit while other answers hold part of it; below kSmallAnswerBytes nothing is
    /// charged.
    void charge_answer(std::uint64_t bytes);
    /// The answers' budget (--answer-budget-mb), for GET /metrics.
    const MemoryBudget& answer_budget() const { return answers_; }

    /// Inside heavy work: one more work slot, held until the last copy of the token goes, for
    /// work that outlives the handler (a streamed answer traces its last chunks while it is
    /// written). Taken without the limit check: the request asking holds a slot already.
    std::shared_ptr<void> extend_work_slot();

    std::size_t requests_in_flight() const { return in_flight_.load(); }
    std::size_t max_concurrent() const { return max_concurrent_; }
    int worker_threads() const { return threads_; }

    /// The registered scenes (the only shared mutable state; it owns its lock).
    SceneRegistry& registry() { return *registry_; }
    /// Builds scenes within the limits: the registry's builder, and the stateless calls'.
    const ModelSource& models() const { return models_; }
    /// Throws 401 unauthorized unless the request carries `Authorization: Bearer <token>` for
    /// the server's --token; does nothing when the server has none.
    void require_write_token(const httplib::Request& req) const;
    /// The registered scene, or scene_not_found.
    std::shared_ptr<const engine::QueryEngine> scene_or_404(const std::string& id);
    static ApiError scene_not_found(const std::string& id);

    /// The counters of GET /metrics (lock-free; see server/metrics.h).
    Metrics& metrics() { return metrics_; }
    /// The exposition of GET /metrics: the counters and, read now, the registry's, the
    /// connections' and the jobs' figures.
    std::string metrics_text() const { return metrics_.render(); }

    /// Adds the registry's figures (scenes, memory, stateless cache hits) to a /v1/info document.
    void add_registry_info(Json& info) const;

  private:
    struct Route {
        std::string pattern;
        const char* method;
    };
    void install_handlers();
    void install_routes();
    /// `handler` with its body read into req.body by read_body() first.
    httplib::Server::HandlerWithContentReader reading_body(httplib::Server::Handler handler);
    /// `handler` behind the access check (the token, before a byte of the body is read).
    httplib::Server::HandlerWithContentReader guarded(
        httplib::Server::HandlerWithContentReader handler, Access access);
    /// Records the route (for Allow and for the metrics); its metrics route index.
    std::size_t remember(const std::string& pattern, const char* method);
    /// Fills in the API's error for a response httplib gave up on (no route, body too large,
    /// malformed HTTP); false for a response a handler has already filled in.
    bool answer_http_error(const httplib::Request& req, httplib::Response& res);
    /// Sends the API error `e` (counted by code).
    void send_error(httplib::Response& res, const ApiError& e);
    /// Logs a bug with the request id and answers 500 internal naming it.
    void send_internal(const httplib::Request& req, httplib::Response& res, const char* what);
    /// The request's metrics and log line, once its answer has been written.
    void close_request(const httplib::Request& req, const httplib::Response& res);
    /// The gauges of GET /metrics that read the registry, connections and work slots.
    void add_gauges();

    /// The charge of the answer `work` left in `res` (handle()); a 503 busy in place of one that
    /// does not fit.
    void charge_written_answer(httplib::Response& res);

    Config config_;
    Metrics metrics_;       ///< before http_: the routes' wrappers use it while http_ serves
    MemoryBudget answers_;  ///< before http_, whose threads hold leases of it
    HttpServer http_;
    int threads_ = 0;
    std::size_t max_concurrent_ = 0;
    std::atomic<std::size_t> in_flight_{0};
    ModelSource models_;
    std::unique_ptr<SceneRegistry> registry_;
    std::vector<Route> routes_;  ///< written while installing, read-only once serving
};

// Route groups, one per file (routes_*.cpp, intersect/routes.cpp).
void install_meta_routes(App& app);
void install_intersect_routes(App& app);
void install_trace_routes(App& app);
void install_scene_routes(App& app);
void install_render_routes(App& app);
void install_points_routes(App& app);  // routes_points.cpp

/// Sends `body` as application/json with the given status.
void send_json(httplib::Response& res, std::string body, int status = 200);

}  // namespace raycastd::server
