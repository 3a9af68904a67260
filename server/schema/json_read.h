#pragma once
// Typed reads from a parsed JSON document, each naming the JSON pointer of what it reads so that
// an error says exactly which input is wrong. Reads go through find()/at(), never operator[].
// parse_json() is the one way a request body becomes JSON.

#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "engine/math/vec3.h"
#include "server/api_error.h"

namespace raycastd::server {

using Json = nlohmann::json;

/// Arrays and objects nest at most this deep in a body. nlohmann builds a document without
/// recursion, but copying, dumping and destroying one recurse, so a 100,000-deep array under
/// an unknown key overflowed the stack (SIGSEGV); no request of the API nests past ~6.
constexpr std::size_t kMaxJsonDepth = 256;

/// The body parsed as JSON: the one reader of every JSON body, so that the same bad body gets
/// the same error on every endpoint. bad_json "body is not valid JSON: byte N: <why>" for an
/// empty body, a syntax error, NaN or Infinity, or a number that overflows a double (1e999);
/// invalid_request for nesting deeper than kMaxJsonDepth (before the deep part is built).
Json parse_json(std::string_view body);
/// parse_json's document, or nullopt where parse_json would throw (for callers that only
/// look, such as content sniffing and content hashing).
std::optional<Json> try_parse_json(std::string_view body);

/// JSON pointer of child `key` of `path`, escaped per RFC 6901 ("~" → "~0", "/" → "~1").
std::string child_path(const std::string& path, const std::string& key);
inline std::string child_path(const std::string& path, std::size_t index) {
    return path + "/" + std::to_string(index);
}

/// A finite number; `code` names the error for a wrong type (invalid_scene, invalid_ray, ...).
/// A number that overflowed to ±inf while parsing is `bad_json`: JSON cannot carry infinity.
double read_number(const Json& j, const std::string& path, ErrorCode code);
/// [x, y, z] of finite numbers.
engine::Vec3d read_vec3(const Json& j, const std::string& path, ErrorCode code);
std::string read_string(const Json& j, const std::string& path, ErrorCode code);
/// The member `key` of object `j`, or nullptr when absent.
const Json* member(const Json& j, const char* key);
/// Throws `code` unless j is an object.
void require_object(const Json& j, const std::string& path, ErrorCode code);

}  // namespace raycastd::server
