#pragma once
// Command-line configuration of raycastd: where to listen, how many threads, and the limits
// that keep one request from taking the whole machine.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "server/request_log.h"

namespace raycastd::server {

struct Limits {
    std::size_t max_body_bytes = 512u << 20;       ///< request body (413 too_large above)
    std::size_t max_rays = 16u << 20;              ///< rays per intersect request
    std::size_t max_points = 16u << 20;            ///< points per points request
    std::size_t max_pixels = 16u << 20;            ///< width × height × spp per render
    std::size_t max_texture_pixels = 16u << 20;    ///< pixels of one texture image (else dropped)
    std::size_t max_triangles = 50'000'000;        ///< triangles per scene
    std::size_t max_concurrent = 0;                ///< work requests in flight (0: 2 × threads)
    std::size_t memory_budget_bytes = 4ull << 30;  ///< resident scenes before LRU eviction
    std::size_t body_budget_bytes = 2ull << 30;    ///< request bodies in flight (503 busy above)
    /// Answers being built or written at once (App::charge_answer; 503 busy above).
    std::size_t answer_budget_bytes = 2ull << 30;
    /// Finished async render images kept; past it the oldest finished jobs are forgotten.
    std::size_t job_budget_bytes = 512ull << 20;
    std::size_t header_timeout_s = 10;  ///< a request head must arrive within this
    std::size_t idle_timeout_s = 5;     ///< a keep-alive connection's wait for its next request
    /// Longest a render, trace, batch or stateless scene build may work before 503 timeout
    /// (server/request_cancel.h); 0: no limit.
    std::size_t request_timeout_s = 0;
};

struct Config {
    std::string host = "127.0.0.1";
    int port = 8080;
    /// Connections served at once, a thread each (0: 512). Connections waiting between
    /// requests give their thread up to new ones (server/http/connections.h).
    int threads = 0;
    std::string scene_root = ".";   ///< mesh `uri`s resolve inside this directory only
    std::string data_dir;           ///< registered scenes persist here ("" = memory only)
    std::vector<std::string> demo;  ///< scene documents registered at start-up
    /// What goes to stderr (server/request_log.h); info: a JSON line per request.
    LogLevel log_level = LogLevel::info;
    /// Writes (POST /v1/scenes, DELETE /v1/scenes/{id}) need `Authorization: Bearer <token>`
    /// when set (--token, else $RAYCASTD_TOKEN); empty: writes are open.
    std::string token;
    Limits limits;
    /// --health-check: ask a running server's GET /v1/health at host:port (0.0.0.0 and ::
    /// meaning this machine) and exit 0 when it answers 200, 1 otherwise; for a container's
    /// HEALTHCHECK, whose runtime image has no curl.
    bool health_check = false;
};

/// The most --max-connections may ask for. Connections are served a thread each; their sockets
/// are only ever waited on with poll(2), ours and cpp-httplib's (Debian's libcpp-httplib 0.11.4
/// is built with CPPHTTPLIB_USE_POLL: it imports poll and not select), so a descriptor past
/// FD_SETSIZE (1024) is served like any other (HttpServer.ServesADescriptorPastFdSetsize).
constexpr std::size_t kMaxConnections = 16384;
/// Descriptors kept besides one per connection: the listening socket, data-dir and scene
/// files, Embree's and TBB's, stdio.
constexpr std::size_t kReservedDescriptors = 256;

/// Makes sure the process may open `connections` + kReservedDescriptors descriptors, raising
/// its soft RLIMIT_NOFILE up to the hard one when needed. False, with `error` naming both
/// figures, when the hard limit is too low.
bool reserve_descriptors(std::size_t connections, std::string& error);

/// Whether `host` names only this machine (127.0.0.0/8, ::1, localhost): a server bound
/// elsewhere without a token lets anyone on the network register and delete scenes.
bool is_loopback_host(const std::string& host);

/// Parses argv over the environment: every option that takes a value may also be given as
/// RAYCASTD_<OPTION> (--max-rays: RAYCASTD_MAX_RAYS), which a flag overrides; an empty
/// RAYCASTD_TOKEN means no token. Returns nullopt and fills `message` for --help (exit 0) or a
/// usage error (`error` set, exit 2), which names the variable when it came from one.
std::optional<Config> parse_args(int argc, char** argv, std::string& message, bool& error);

/// "--max-rays" → "RAYCASTD_MAX_RAYS".
std::string env_name(const std::string& flag);

/// The --help text.
std::string usage();

}  // namespace raycastd::server
