#include "server/api_error.h"

#include <map>

#include <nlohmann/json.hpp>

namespace raycastd::server {

namespace {

const std::map<std::string, int>& table() {
    static const std::map<std::string, int> t = {
        {"bad_json", 400},           {"invalid_scene", 400},
        {"invalid_ray", 400},        {"invalid_request", 400},
        {"unsupported_format", 400}, {"scene_not_found", 404},
        {"not_found", 404},          {"method_not_allowed", 405},
        {"too_large", 413},          {"unsupported_media_type", 415},
        {"model_load_failed", 422},  {"busy", 503},
        {"internal", 500},
    };
    return t;
}

const char* code_name(engine::Code c) {
    switch (c) {
        case engine::Code::ok:
            return "internal";
        case engine::Code::invalid_scene:
            return "invalid_scene";
        case engine::Code::invalid_ray:
            return "invalid_ray";
        case engine::Code::invalid_request:
            return "invalid_request";
        case engine::Code::model_load_failed:
            return "model_load_failed";
        case engine::Code::unsupported_format:
            return "unsupported_format";
        case engine::Code::too_large:
            return "too_large";
        case engine::Code::not_found:
            return "not_found";
        case engine::Code::internal:
            return "internal";
    }
    return "internal";
}

}  // namespace

int http_status_of(const std::string& code) {
    auto it = table().find(code);
    return it == table().end() ? 500 : it->second;
}

ApiError api_error(const std::string& code, std::string message, std::string path) {
    return ApiError(code, http_status_of(code), std::move(message), std::move(path));
}

ApiError from_status(const engine::Status& st, const std::string& path_prefix) {
    std::string path = st.path.empty() ? std::string() : path_prefix + st.path;
    return api_error(code_name(st.code), st.message, std::move(path));
}

std::string error_body(const ApiError& e) {
    nlohmann::json err = {{"code", e.code}, {"message", e.what()}};
    if (!e.path.empty())
        err["path"] = e.path;
    return nlohmann::json{{"error", err}}.dump(-1, ' ', false,
                                               nlohmann::json::error_handler_t::replace);
}

}  // namespace raycastd::server
