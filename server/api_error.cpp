#include "server/api_error.h"

#include <array>
#include <ostream>

#include <nlohmann/json.hpp>

namespace raycastd::server {

namespace {

struct Entry {
    ErrorCode code;
    int status;
    std::string_view name;
};

/// The table: every code once, with its HTTP status and its name (docs/api.md, "Errors").
constexpr std::array<Entry, 16> kTable = {{
    {ErrorCode::bad_json, 400, "bad_json"},
    {ErrorCode::invalid_scene, 400, "invalid_scene"},
    {ErrorCode::invalid_ray, 400, "invalid_ray"},
    {ErrorCode::invalid_request, 400, "invalid_request"},
    {ErrorCode::unsupported_format, 400, "unsupported_format"},
    {ErrorCode::unauthorized, 401, "unauthorized"},
    {ErrorCode::scene_not_found, 404, "scene_not_found"},
    {ErrorCode::not_found, 404, "not_found"},
    {ErrorCode::job_not_found, 404, "job_not_found"},
    {ErrorCode::method_not_allowed, 405, "method_not_allowed"},
    {ErrorCode::too_large, 413, "too_large"},
    {ErrorCode::model_load_failed, 422, "model_load_failed"},
    {ErrorCode::busy, 503, "busy"},
    {ErrorCode::timeout, 503, "timeout"},
    {ErrorCode::insufficient_storage, 507, "insufficient_storage"},
    {ErrorCode::internal, 500, "internal"},
}};

constexpr bool table_in_enum_order() {
    for (std::size_t i = 0; i < kTable.size(); ++i) {
        if (static_cast<std::size_t>(kTable[i].code) != i)
            return false;
    }
    return static_cast<std::size_t>(ErrorCode::internal) + 1 == kTable.size();
}
static_assert(table_in_enum_order(), "kTable must list every ErrorCode once, in enum order");

const Entry& entry(ErrorCode code) {
    return kTable[static_cast<std::size_t>(code)];
}

ErrorCode from_engine(engine::Code c) {
    switch (c) {
        case engine::Code::invalid_scene:
            return ErrorCode::invalid_scene;
        case engine::Code::invalid_ray:
            return ErrorCode::invalid_ray;
        case engine::Code::invalid_request:
            return ErrorCode::invalid_request;
        case engine::Code::model_load_failed:
            return ErrorCode::model_load_failed;
        case engine::Code::unsupported_format:
            return ErrorCode::unsupported_format;
        case engine::Code::too_large:
            return ErrorCode::too_large;
        case engine::Code::not_found:
            // A file or resource a document refers to; the API's not_found is an endpoint.
            return ErrorCode::invalid_scene;
        case engine::Code::cancelled:
            // Work a request's own token stopped: its client has gone (and reads no answer) or
            // it ran past the time limit, which the server words itself (request_cancel.h).
            return ErrorCode::timeout;
        case engine::Code::ok:  // not an error: reporting it is a bug
        case engine::Code::internal:
            return ErrorCode::internal;
    }
    return ErrorCode::internal;
}

}  // namespace

std::string_view to_string(ErrorCode code) {
    return entry(code).name;
}

int http_status_of(ErrorCode code) {
    return entry(code).status;
}

std::ostream& operator<<(std::ostream& os, ErrorCode code) {
    return os << to_string(code);
}

ApiError from_status(const engine::Status& st, const std::string& path_prefix) {
    std::string path = st.path.empty() ? std::string() : path_prefix + st.path;
    return ApiError(from_engine(st.code), st.message, std::move(path));
}

std::string error_body(const ApiError& e) {
    nlohmann::json err = {{"code", std::string(to_string(e.code))}, {"message", e.message}};
    if (!e.path.empty())
        err["path"] = e.path;
    return nlohmann::json{{"error", err}}.dump(-1, ' ', false,
                                               nlohmann::json::error_handler_t::replace);
}

}  // namespace raycastd::server
