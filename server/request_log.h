#pragma once
// The request being served on this thread, and its log line. App opens a record when a
// request's head has been read (the pre-routing handler), the route's wrapper names its route,
// the routes add the rays they trace, and cpp-httplib's logger (called on the same thread once
// the answer is written) closes it: one metrics observation and, by --log-level, one JSON line
// on stderr carrying the X-Request-Id the client was given.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "server/metrics.h"

namespace raycastd::server {

/// --log-level, lowest first: error logs internal errors only; warn adds the request lines of
/// 5xx answers; info adds every request's line; debug adds the raw path and the body sizes.
enum class LogLevel { error, warn, info, debug };

/// "error", "warn", "info", "debug" → the level; nullopt otherwise.
std::optional<LogLevel> parse_log_level(std::string_view name);
const char* to_string(LogLevel level);

struct RequestRecord {
    bool open = false;      ///< false outside a request (and for a request httplib could not read)
    std::size_t route = 0;  ///< Metrics route index; 0: no route matched
    std::chrono::steady_clock::time_point start;
    std::uint64_t rays = 0;
    Metrics* metrics = nullptr;
};

/// This thread's record (open only while it serves a request).
RequestRecord& current_request();

/// Counts `n` rays in the metrics of the request served on this thread, and in its log line.
/// Nothing outside a request: work on other threads (async render jobs) counts through
/// Metrics::count_rays itself.
void note_rays(RayKind kind, engine::Precision precision, std::uint64_t n);
/// Counts `n` rays in `metrics`, and in the log line of the request served on this thread when
/// there is one (a synchronous render; an async render's job thread has none).
void note_rays(Metrics& metrics, RayKind kind, engine::Precision precision, std::uint64_t n);

/// What one log line says about a request.
struct RequestLogEntry {
    std::string_view request_id, method, route, path;
    int status = 0;
    double duration_ms = 0;
    std::uint64_t rays = 0;
    std::size_t request_bytes = 0, response_bytes = 0;
};

/// One JSON object, without the newline: {"ts":...,"level":"info","msg":"request",
/// "request_id":...,"method":...,"route":...,"status":...,"duration_ms":...,"rays":...}, with
/// "path", "request_bytes" and "response_bytes" at debug. The timestamp is UTC, RFC 3339 with
/// milliseconds.
std::string request_log_line(const RequestLogEntry& e, LogLevel level);

/// Whether a request answered with `status` is logged at `level`.
bool logs_request(LogLevel level, int status);

/// {"ts":...,"level":...,"msg":...} plus "request_id" when given: for messages that are not
/// request lines (internal errors).
std::string message_log_line(LogLevel level, std::string_view msg,
                             std::string_view request_id = {});

}  // namespace raycastd::server
