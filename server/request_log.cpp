#include "server/request_log.h"

#include <ctime>

#include "server/schema/json_writer.h"

namespace raycastd::server {

namespace {

thread_local RequestRecord t_request;

/// "2026-12-01T23:00:01.123Z"
std::string utc_now() {
    const auto now = std::chrono::system_clock::now();
    const std::time_t secs = std::chrono::system_clock::to_time_t(now);
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch() %
                                                                          std::chrono::seconds(1))
                        .count();
    std::tm tm{};
    ::gmtime_r(&secs, &tm);
    char buf[40];
    const std::size_t n = std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
    std::snprintf(buf + n, sizeof buf - n, ".%03dZ", static_cast<int>(ms));
    return buf;
}

void open_line(JsonWriter& w, LogLevel level, std::string_view msg) {
    w.raw("{\"ts\":").string(utc_now());
    w.raw(",\"level\":").string(to_string(level));
    w.raw(",\"msg\":").string(msg);
}

}  // namespace

std::optional<LogLevel> parse_log_level(std::string_view name) {
    for (LogLevel l : {LogLevel::error, LogLevel::warn, LogLevel::info, LogLevel::debug}) {
        if (name == to_string(l))
            return l;
    }
    return std::nullopt;
}

const char* to_string(LogLevel level) {
    switch (level) {
        case LogLevel::error:
            return "error";
        case LogLevel::warn:
            return "warn";
        case LogLevel::info:
            return "info";
        case LogLevel::debug:
            return "debug";
    }
    return "info";
}

RequestRecord& current_request() {
    return t_request;
}

void note_rays(RayKind kind, engine::Precision precision, std::uint64_t n) {
    if (!t_request.open || !t_request.metrics)
        return;
    t_request.rays += n;
    t_request.metrics->count_rays(kind, precision, n);
}

void note_rays(Metrics& metrics, RayKind kind, engine::Precision precision, std::uint64_t n) {
    metrics.count_rays(kind, precision, n);
    if (t_request.open)
        t_request.rays += n;
}

bool logs_request(LogLevel level, int status) {
    return level >= LogLevel::info || (level == LogLevel::warn && status >= 500);
}

std::string request_log_line(const RequestLogEntry& e, LogLevel level) {
    std::string out;
    JsonWriter w(out);
    // A 5xx line is a warning: the server (not the client) could not do the work.
    open_line(w, e.status >= 500 ? LogLevel::warn : LogLevel::info, "request");
    w.raw(",\"request_id\":").string(e.request_id);
    w.raw(",\"method\":").string(e.method);
    w.raw(",\"route\":").string(e.route);
    w.raw(",\"status\":").integer(static_cast<std::uint64_t>(e.status));
    char ms[32];
    std::snprintf(ms, sizeof ms, "%.3f", e.duration_ms);
    w.raw(",\"duration_ms\":").raw(ms);
    w.raw(",\"rays\":").integer(e.rays);
    if (level == LogLevel::debug) {
        w.raw(",\"path\":").string(e.path);
        w.raw(",\"request_bytes\":").integer(e.request_bytes);
        w.raw(",\"response_bytes\":").integer(e.response_bytes);
    }
    w.ch('}');
    return out;
}

std::string message_log_line(LogLevel level, std::string_view msg, std::string_view request_id) {
    std::string out;
    JsonWriter w(out);
    open_line(w, level, msg);
    if (!request_id.empty())
        w.raw(",\"request_id\":").string(request_id);
    w.ch('}');
    return out;
}

}  // namespace raycastd::server
