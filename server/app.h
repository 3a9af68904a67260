#pragma once
// App: the HTTP front of raycastd. Builds the httplib::Server (routes, error and exception
// handlers, request ids, limits) over the engine; owns the scene registry.

#include <atomic>
#include <functional>
#include <memory>
#include <string>

#include <httplib.h>

#include "engine/query/intersect.h"
#include "server/api_error.h"
#include "server/config.h"
#include "server/scene_cache.h"
#include "server/scene_registry.h"
#include "server/schema/binary_codec.h"
#include "server/schema/json_read.h"
#include "server/schema/query_doc.h"
#include "server/scratch.h"
#include "server/uri_resolver.h"

namespace raycastd::server {

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
    httplib::Server& http() { return http_; }

    /// Runs `work` and turns what it throws into the API's JSON error responses.
    /// `heavy` work takes one of the limited concurrent-work slots (503 busy when none is free).
    void handle(const httplib::Request& req, httplib::Response& res, bool heavy,
                const std::function<void()>& work);

    /// Inside heavy work: one more work slot, held until the last copy of the token goes, for
    /// work that outlives the handler (a streamed answer traces its last chunks while it is
    /// written). Taken without the limit check: the request asking holds a slot already.
    std::shared_ptr<void> extend_work_slot();

    /// The body parsed as JSON (bad_json with the byte offset on a syntax error).
    static Json parse_json_body(const httplib::Request& req);

    std::size_t requests_in_flight() const { return in_flight_.load(); }
    std::size_t max_concurrent() const { return max_concurrent_; }
    int worker_threads() const { return threads_; }

    /// Parses a scene document of a stateless call and prepares it for queries (ApiError on
    /// any problem; paths start with `prefix`).
    std::shared_ptr<const engine::QueryEngine> build_stateless_scene(
        const Json& doc, const std::string& prefix) const;
    SceneRegistry& registry() { return *registry_; }
    /// Reads files under --scene-root (confined; see uri_resolver.h).
    FileSource scene_root_files() const;
    /// The registered scene, or scene_not_found.
    std::shared_ptr<const engine::QueryEngine> scene_or_404(const std::string& id);
    static ApiError scene_not_found(const std::string& id);
    /// "application/json" for a scene document, or the model content type of a raw model body
    /// (sniffed when the client sent none or a generic one); unsupported_format otherwise.
    std::string classify_scene_body(const httplib::Request& req) const;
    /// Builds a prepared scene from a registry source (the registry's Builder).
    std::shared_ptr<const engine::QueryEngine> build_scene(const SceneSource& source,
                                                           const FileSource& files) const;

    /// Adds the registry's figures (scenes, memory) to a /v1/info document.
    void add_registry_info(Json& info) const;

  private:
    void install_routes();

    Config config_;
    httplib::Server http_;
    int threads_ = 0;
    std::size_t max_concurrent_ = 0;
    std::atomic<std::size_t> in_flight_{0};
    std::atomic<std::uint64_t> next_request_id_{1};
    std::unique_ptr<SceneRegistry> registry_;
    mutable SceneCache stateless_cache_{32};
    SceneRoot scene_root_;
};

// Route groups, one per file (routes_*.cpp).
void install_meta_routes(App& app);
void install_query_routes(App& app);
void install_trace_routes(App& app);
void install_scene_routes(App& app);
void install_render_routes(App& app);

/// Parses an intersect body and answers it over `engine` (shared by the stateless and the
/// registered-scene routes).
void answer_intersect(const engine::QueryEngine& engine, const Json& body,
                      const std::string& prefix, std::size_t max_rays, httplib::Response& res);
/// Answers an already parsed intersect request in JSON, the engine answering into `result`.
void answer_parsed_intersect(const engine::QueryEngine& engine, const IntersectRequest& req,
                             engine::QueryResult& result, httplib::Response& res);
/// True when the request carries binary ray records (Content-Type: application/octet-stream).
bool is_binary(const httplib::Request& req);
/// The query string of the binary form: ?mode=&precision=&dtype=&fields=.
struct BinaryQuery {
    engine::QueryOptions options;
    Dtype dtype = Dtype::float32;
};
BinaryQuery parse_binary_query(const httplib::Request& req);
/// Sends the encoded answer in scratch->out, answered at `precision`; the response streams from
/// `scratch`, which it keeps until written.
void send_binary_answer(const BinaryQuery& q, engine::Precision precision,
                        std::shared_ptr<Scratch> scratch, httplib::Response& res);
class StreamedBatch;
/// Sends the answer of a streamed batch (server/binary_stream.h) after its finish(): chunks are
/// written as they are traced.
/// `slot` (App::extend_work_slot) is held until the answer is written.
void send_streamed_answer(std::shared_ptr<StreamedBatch> batch, std::shared_ptr<void> slot,
                          httplib::Response& res);
/// Answers the binary form (see schema/binary_codec.h) from the query string and
/// `scratch->body`; the response streams from `scratch`, which it keeps until written.
void answer_binary_intersect(const engine::QueryEngine& engine, const httplib::Request& req,
                             std::shared_ptr<Scratch> scratch, std::size_t max_rays,
                             httplib::Response& res);

/// Sends `body` as application/json with the given status.
void send_json(httplib::Response& res, std::string body, int status = 200);

}  // namespace raycastd::server
