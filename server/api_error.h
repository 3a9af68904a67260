#pragma once
// ApiError: the one table of error codes of the HTTP API (API.md, "Errors"). Every code is
// defined here once, maps to one HTTP status, and is documented in docs/api.md.

#include <stdexcept>
#include <string>

#include "engine/status.h"

namespace raycastd::server {

struct ApiError : std::runtime_error {
    std::string code;  ///< stable machine code: "bad_json", "invalid_scene", ...
    int http_status;
    std::string path;  ///< JSON pointer into the request body, empty when not applicable

    ApiError(std::string code_, int status, std::string message, std::string path_ = {})
        : std::runtime_error(std::move(message)),
          code(std::move(code_)),
          http_status(status),
          path(std::move(path_)) {}
};

/// The HTTP status of a code from the table; 500 for an unknown code (a bug).
int http_status_of(const std::string& code);

/// An ApiError with the status the table gives the code.
ApiError api_error(const std::string& code, std::string message, std::string path = {});

/// Maps an engine Status (not ok) to the API's code and status; `path_prefix` is prepended to
/// the Status path (e.g. "/scene" for the stateless calls).
ApiError from_status(const engine::Status& st, const std::string& path_prefix = {});

/// {"error": {"code": ..., "message": ..., "path": ...}} (path only when set).
std::string error_body(const ApiError& e);

}  // namespace raycastd::server
