#pragma once
// ApiError: the one table of error codes of the HTTP API (docs/api.md, "Errors"). Every code is
// an ErrorCode, defined here once, with one HTTP status and one stable name; a misspelt code is
// a compile error, not a 500.

#include <iosfwd>
#include <stdexcept>
#include <string>
#include <string_view>

#include "engine/status.h"

namespace raycastd::server {

/// The API's stable machine codes, in the order of the table in api_error.cpp.
enum class ErrorCode {
    bad_json,              ///< 400: the body is not JSON (or holds a number a double cannot carry)
    invalid_scene,         ///< 400: a scene document breaks a rule
    invalid_ray,           ///< 400: a ray is unusable; names the ray index
    invalid_request,       ///< 400: an unusable option, a missing member, malformed HTTP
    unsupported_format,    ///< 400: a format raycastd does not read or write
    unauthorized,          ///< 401: a write without the bearer token the server was started with
    scene_not_found,       ///< 404: no registered scene has that id
    not_found,             ///< 404: no such endpoint
    job_not_found,         ///< 404: no render job has that id
    method_not_allowed,    ///< 405: a known path with another method (Allow lists the right ones)
    too_large,             ///< 413: over a configured limit, or out of memory
    model_load_failed,     ///< 422: the file parsed but is not a usable model
    busy,                  ///< 503: over the concurrent-work limit
    timeout,               ///< 503: past --request-timeout-s; the work was cancelled
    insufficient_storage,  ///< 507: the data dir is full or read-only; nothing was changed
    internal,              ///< 500: a bug
};

/// The code's stable name as it appears in responses ("bad_json").
std::string_view to_string(ErrorCode code);
/// The HTTP status the table gives the code.
int http_status_of(ErrorCode code);
/// Writes to_string(code) (for test messages).
std::ostream& operator<<(std::ostream& os, ErrorCode code);

struct ApiError : std::runtime_error {
    ErrorCode code;
    std::string path;  ///< JSON pointer into the request body, empty when not applicable
    /// The whole message: what() is a C string, which a NUL byte from the request (a key
    /// quoted in the message) would cut short.
    std::string message;

    ApiError(ErrorCode code_, std::string message_, std::string path_ = {})
        : std::runtime_error(message_),
          code(code_),
          path(std::move(path_)),
          message(std::move(message_)) {}

    int http_status() const { return http_status_of(code); }
};

/// Maps an engine Status (not ok) to the API's code; `path_prefix` is prepended to the Status
/// path (e.g. "/scene" for the stateless calls). The only mapping from engine::Code.
ApiError from_status(const engine::Status& st, const std::string& path_prefix = {});

/// {"error": {"code": ..., "message": ..., "path": ...}} (path only when set).
std::string error_body(const ApiError& e);

}  // namespace raycastd::server
