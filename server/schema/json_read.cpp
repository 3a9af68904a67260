#include "server/schema/json_read.h"

#include <cmath>

namespace raycastd::server {

std::string child_path(const std::string& path, const std::string& key) {
    std::string out = path + "/";
    for (char c : key) {
        if (c == '~') {
            out += "~0";
        } else if (c == '/') {
            out += "~1";
        } else {
            out += c;
        }
    }
    return out;
}

double read_number(const Json& j, const std::string& path, const char* code) {
    if (!j.is_number())
        throw api_error(code, path + " must be a number", path);
    const double v = j.get<double>();
    if (!std::isfinite(v)) {
        throw api_error("bad_json", path + " is out of range (JSON cannot carry infinity)", path);
    }
    return v;
}

engine::Vec3d read_vec3(const Json& j, const std::string& path, const char* code) {
    if (!j.is_array() || j.size() != 3) {
        throw api_error(code, path + " must be an array of 3 numbers", path);
    }
    return {read_number(j.at(0), path + "/0", code), read_number(j.at(1), path + "/1", code),
            read_number(j.at(2), path + "/2", code)};
}

std::string read_string(const Json& j, const std::string& path, const char* code) {
    if (!j.is_string())
        throw api_error(code, path + " must be a string", path);
    return j.get<std::string>();
}

const Json* member(const Json& j, const char* key) {
    auto it = j.find(key);
    return it == j.end() ? nullptr : &*it;
}

void require_object(const Json& j, const std::string& path, const char* code) {
    if (!j.is_object()) {
        throw api_error(
            code, (path.empty() ? std::string("the body") : path) + " must be an object", path);
    }
}

}  // namespace raycastd::server
