#include "server/schema/ray_scanner.h"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <vector>

namespace raycastd::server {

namespace {

// A hand-written scanner for the one shape that matters, {"rays":[{"origin":[x,y,z],
// "direction":[x,y,z],"tmin":t,"tmax":t},...],"mode":"..","precision":"..","fields":[..]}:
// numbers are read with std::from_chars (libstdc++ 12: correctly rounded, like strtod, but
// several times faster), strings only as plain ASCII. nlohmann's SAX lexer, used before, spent
// 55% of a 10,000-ray request in its number scanner and strtod (perf, docs/benchmarks.md).
// Anything it does not recognise (an escape in a string, non-ASCII bytes, a value of another
// type, a syntax error, nesting deeper than kMaxDepth) makes it give up: the caller then parses
// with the DOM reader, the reference for every answer and every error message.
class Scanner {
  public:
    Scanner(std::string_view body, std::size_t max_rays, IntersectRequest& out)
        : p_(body.data()), end_(body.data() + body.size()), max_rays_(max_rays), out_(out) {}

    std::vector<std::string> fields;
    std::string mode, precision;
    bool has_fields = false, has_mode = false, has_precision = false, has_rays = false;

    /// The whole body: one object, then only whitespace.
    bool document() {
        if (!object([this](std::string_view key) { return top_member(key); }))
            return false;
        ws();
        return p_ == end_;
    }

  private:
    static constexpr int kMaxDepth = 64;

    void ws() {
        while (p_ != end_ && (*p_ == ' ' || *p_ == '\n' || *p_ == '\r' || *p_ == '\t'))
            ++p_;
    }
    bool eat(char c) {
        ws();
        if (p_ == end_ || *p_ != c)
            return false;
        ++p_;
        return true;
    }

    /// A string of printable ASCII without escapes (else: give up).
    bool plain_string(std::string_view& s) {
        if (!eat('"'))
            return false;
        const char* b = p_;
        while (p_ != end_ && *p_ != '"') {
            const auto c = static_cast<unsigned char>(*p_);
            if (c < 0x20 || c >= 0x80 || c == '\\')
                return false;
            ++p_;
        }
        if (p_ == end_)
            return false;
        s = std::string_view(b, static_cast<std::size_t>(p_ - b));
        ++p_;
        return true;
    }

    /// One or more decimal digits; false (nothing consumed) when there is none.
    bool digits() {
        const char* d = p_;
        while (p_ != end_ && *p_ >= '0' && *p_ <= '9')
            ++p_;
        return p_ != d;
    }

    /// A JSON number, converted as nlohmann's reader converts it: a token without fraction or
    /// exponent that fits a 64-bit integer is that integer (so "-0" is +0.0), anything else the
    /// correctly rounded double; out of range (1e400) gives up.
    bool number(double& v) {
        ws();
        const char* b = p_;
        if (p_ != end_ && *p_ == '-')
            ++p_;
        if (p_ == end_)
            return false;
        if (*p_ == '0') {
            ++p_;
        } else if (!(*p_ >= '1' && *p_ <= '9') || !digits()) {
            return false;
        }
        bool integer = true;
        if (p_ != end_ && *p_ == '.') {
            integer = false;
            ++p_;
            if (!digits())
                return false;
        }
        if (p_ != end_ && (*p_ == 'e' || *p_ == 'E')) {
            integer = false;
            ++p_;
            if (p_ != end_ && (*p_ == '+' || *p_ == '-'))
                ++p_;
            if (!digits())
                return false;
        }
        if (integer) {
            if (*b == '-') {
                std::int64_t i = 0;
                if (std::from_chars(b, p_, i).ec == std::errc()) {
                    v = static_cast<double>(i);
                    return true;
                }
            } else {
                std::uint64_t u = 0;
                if (std::from_chars(b, p_, u).ec == std::errc()) {
                    v = static_cast<double>(u);
                    return true;
                }
            }
        }
        const auto r = std::from_chars(b, p_, v);
        return r.ec == std::errc() && r.ptr == p_ && std::isfinite(v);
    }

    /// open item, item, ... close (possibly empty), item() reading one.
    template <class Item>
    bool sequence(char open, char close, Item&& item) {
        if (!eat(open))
            return false;
        if (eat(close))
            return true;
        do {
            if (!item())
                return false;
        } while (eat(','));
        return eat(close);
    }
    /// {"key": value, ...}, member(key) reading each value.
    template <class Member>
    bool object(Member&& member) {
        return sequence('{', '}', [&] {
            std::string_view key;
            return plain_string(key) && eat(':') && member(key);
        });
    }
    /// [value, ...], element() reading each value.
    template <class Element>
    bool array(Element&& element) {
        return sequence('[', ']', element);
    }

    /// A value nobody reads (the DOM reader ignores unknown keys too).
    bool skip(int depth = 0) {
        if (depth > kMaxDepth)
            return false;
        ws();
        if (p_ == end_)
            return false;
        switch (*p_) {
            case '{':
                return object([&](std::string_view) { return skip(depth + 1); });
            case '[':
                return array([&] { return skip(depth + 1); });
            case '"': {
                std::string_view s;
                return plain_string(s);
            }
            case 't':
                return literal("true");
            case 'f':
                return literal("false");
            case 'n':
                return literal("null");
            default: {
                double v;
                return number(v);
            }
        }
    }
    bool literal(std::string_view word) {
        if (static_cast<std::size_t>(end_ - p_) < word.size() ||
            std::string_view(p_, word.size()) != word) {
            return false;
        }
        p_ += word.size();
        return true;
    }

    bool top_member(std::string_view key) {
        if (key == "rays") {
            has_rays = true;
            out_.rays.clear();
            return array([this] { return ray(); });
        }
        if (key == "fields") {
            has_fields = true;
            fields.clear();
            return array([this] {
                std::string_view s;
                if (!plain_string(s))
                    return false;
                fields.emplace_back(s);
                return true;
            });
        }
        if (key == "mode" || key == "precision") {
            std::string_view s;
            if (!plain_string(s))
                return false;
            (key == "mode" ? mode : precision) = std::string(s);
            (key == "mode" ? has_mode : has_precision) = true;
            return true;
        }
        return skip();
    }

    bool vec3(engine::Vec3d& v) {
        std::size_t n = 0;
        const bool ok = array([&] {
            if (n == 3)
                return false;
            return number(v[n++]);
        });
        return ok && n == 3;
    }

    bool ray() {
        if (out_.rays.size() >= max_rays_)
            return false;  // DOM: too_large with the real count
        engine::Ray& r = out_.rays.emplace_back();
        bool origin = false, direction = false;
        const bool ok = object([&](std::string_view key) {
            if (key == "origin")
                return origin = vec3(r.origin);
            if (key == "direction")
                return direction = vec3(r.direction);
            if (key == "tmin")
                return number(r.tmin);
            if (key == "tmax")
                return number(r.tmax);
            return skip();
        });
        return ok && origin && direction;
    }

    const char* p_;
    const char* end_;
    std::size_t max_rays_;
    IntersectRequest& out_;
};

}  // namespace

bool scan_intersect_request(std::string_view body, std::size_t max_rays, IntersectRequest& out) {
    out.rays.clear();
    Scanner s(body, max_rays, out);
    if (!s.document() || !s.has_rays)
        return false;
    if (s.has_mode)
        out.options.mode = parse_mode(s.mode, "/mode");
    if (s.has_precision)
        out.options.precision = parse_precision(s.precision, "/precision");
    if (s.has_fields) {
        Json f = Json::array();
        for (auto& name : s.fields)
            f.push_back(std::move(name));
        out.fields = parse_fields(f, "/fields");
    }
    out.options.want_normal = out.fields.needs_normals();
    for (std::size_t i = 0; i < out.rays.size(); ++i) {
        engine::Status st = engine::validate_ray(out.rays[i], i);
        if (!st.ok())
            throw from_status(st);
    }
    return true;
}

}  // namespace raycastd::server
