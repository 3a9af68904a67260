#include "server/schema/json_read.h"

#include <cmath>

namespace raycastd::server {

namespace {

/// nlohmann's own DOM builder, except that an error becomes our bad_json with the byte offset:
/// nlohmann passes it to the SAX handler for every error, but its out_of_range exceptions (a
/// number overflowing a double, 406) do not carry it.
class DomBuilder : public nlohmann::detail::json_sax_dom_parser<Json> {
  public:
    using json_sax_dom_parser::json_sax_dom_parser;

    template <class Exception>
    bool parse_error(std::size_t byte, const std::string& /*token*/, const Exception& ex) {
        throw ApiError(ErrorCode::bad_json,
                       "body is not valid JSON: byte " + std::to_string(byte) + ": " + ex.what());
    }
    // Hides the base's (sax_parse is a template over this type): the depth is counted as the
    // document is built, and a body is refused at the first level past the limit.
    bool start_object(std::size_t n) { return deeper() && json_sax_dom_parser::start_object(n); }
    bool start_array(std::size_t n) { return deeper() && json_sax_dom_parser::start_array(n); }
    bool end_object() {
        --depth_;
        return json_sax_dom_parser::end_object();
    }
    bool end_array() {
        --depth_;
        return json_sax_dom_parser::end_array();
    }

  private:
    bool deeper() {
        if (++depth_ > kMaxJsonDepth) {
            throw ApiError(ErrorCode::invalid_request,
                           "the body nests arrays and objects deeper than " +
                               std::to_string(kMaxJsonDepth) + " levels");
        }
        return true;
    }
    std::size_t depth_ = 0;
};

}  // namespace

Json parse_json(std::string_view body) {
    Json doc;
    DomBuilder builder(doc);
    Json::sax_parse(body, &builder);
    return doc;
}

std::optional<Json> try_parse_json(std::string_view body) {
    try {
        return parse_json(body);
    } catch (const ApiError&) {
        return std::nullopt;
    }
}

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

double read_number(const Json& j, const std::string& path, ErrorCode code) {
    if (!j.is_number())
        throw ApiError(code, path + " must be a number", path);
    const double v = j.get<double>();
    if (!std::isfinite(v)) {
        throw ApiError(ErrorCode::bad_json, path + " is out of range (JSON cannot carry infinity)",
                       path);
    }
    return v;
}

engine::Vec3d read_vec3(const Json& j, const std::string& path, ErrorCode code) {
    if (!j.is_array() || j.size() != 3) {
        throw ApiError(code, path + " must be an array of 3 numbers", path);
    }
    return {read_number(j.at(0), path + "/0", code), read_number(j.at(1), path + "/1", code),
            read_number(j.at(2), path + "/2", code)};
}

std::string read_string(const Json& j, const std::string& path, ErrorCode code) {
    if (!j.is_string())
        throw ApiError(code, path + " must be a string", path);
    return j.get<std::string>();
}

const Json* member(const Json& j, const char* key) {
    auto it = j.find(key);
    return it == j.end() ? nullptr : &*it;
}

void require_object(const Json& j, const std::string& path, ErrorCode code) {
    if (!j.is_object()) {
        throw ApiError(code, (path.empty() ? std::string("the body") : path) + " must be an object",
                       path);
    }
}

}  // namespace raycastd::server
