#pragma once
// Typed reads from a parsed JSON document, each naming the JSON pointer of what it reads so that
// an error says exactly which input is wrong. Reads go through find()/at(), never operator[].

#include <string>

#include <nlohmann/json.hpp>

#include "engine/math/vec3.h"
#include "server/api_error.h"

namespace raycastd::server {

using Json = nlohmann::json;

/// JSON pointer of child `key` of `path`, escaped per RFC 6901 ("~" → "~0", "/" → "~1").
std::string child_path(const std::string& path, const std::string& key);
inline std::string child_path(const std::string& path, std::size_t index) {
    return path + "/" + std::to_string(index);
}

/// A finite number; `code` names the error for a wrong type (invalid_scene, invalid_ray, ...).
/// A number that overflowed to ±inf while parsing is `bad_json`: JSON cannot carry infinity.
double read_number(const Json& j, const std::string& path, const char* code);
/// [x, y, z] of finite numbers.
engine::Vec3d read_vec3(const Json& j, const std::string& path, const char* code);
std::string read_string(const Json& j, const std::string& path, const char* code);
/// The member `key` of object `j`, or nullptr when absent.
const Json* member(const Json& j, const char* key);
/// Throws `code` unless j is an object.
void require_object(const Json& j, const std::string& path, const char* code);

}  // namespace raycastd::server
