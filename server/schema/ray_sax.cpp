#include "server/schema/ray_sax.h"

#include <cmath>
#include <vector>

namespace raycastd::server {

namespace {

/// Where in the expected shape the next event lands.
enum class At {
    start,       // before the top-level object
    top,         // in the top-level object, expecting a key or its end
    top_value,   // after a top-level key, expecting its value
    rays,        // in the rays array, expecting a ray object or the end
    ray,         // in a ray object, expecting a key or its end
    ray_value,   // after a key of a ray
    vec,         // in origin/direction, expecting numbers
    fields,      // in the fields array, expecting strings
    done,
};

class Handler : public nlohmann::json_sax<Json> {
public:
    Handler(std::size_t max_rays, IntersectRequest& out) : max_rays_(max_rays), out_(out) {}

    std::vector<std::string> fields;
    bool has_fields = false;
    std::string mode, precision;
    bool has_mode = false, has_precision = false, has_rays = false;
    bool too_many = false;

    bool null() override { return skip_scalar(); }
    bool boolean(bool) override { return skip_scalar(); }
    bool number_integer(number_integer_t v) override { return number(static_cast<double>(v)); }
    bool number_unsigned(number_unsigned_t v) override { return number(static_cast<double>(v)); }
    bool number_float(number_float_t v, const string_t&) override { return number(v); }
    bool binary(binary_t&) override { return false; }
    bool string(string_t& s) override {
        if (skip_ > 0) return skip_scalar();
        if (at_ == At::fields) {
            fields.push_back(s);
            return true;
        }
        if (at_ == At::top_value) {
            if (key_ == "mode") {
                mode = s;
                has_mode = true;
            } else if (key_ == "precision") {
                precision = s;
                has_precision = true;
            } else if (key_ == "rays" || key_ == "fields") {
                return false;  // wrong type: let the DOM reader say so
            }
            at_ = At::top;
            return true;
        }
        if (at_ == At::ray_value) {
            if (is_ray_field()) return false;
            at_ = At::ray;
            return true;
        }
        return false;
    }
    bool start_object(std::size_t) override {
        if (skip_ > 0 || unknown_value()) {
            ++skip_;
            return true;
        }
        if (at_ == At::start) {
            at_ = At::top;
            return true;
        }
        if (at_ == At::rays) {
            if (out_.rays.size() >= max_rays_) {
                too_many = true;
                return false;
            }
            out_.rays.emplace_back();
            have_origin_ = have_direction_ = false;
            at_ = At::ray;
            return true;
        }
        return false;
    }
    bool key(string_t& k) override {
        if (skip_ > 0) return true;
        if (at_ == At::top) {
            key_ = k;
            at_ = At::top_value;
            return true;
        }
        if (at_ == At::ray) {
            key_ = k;
            at_ = At::ray_value;
            return true;
        }
        return false;
    }
    bool end_object() override {
        if (skip_ > 0) return end_skip();
        if (at_ == At::ray) {
            if (!have_origin_ || !have_direction_) return false;
            at_ = At::rays;
            return true;
        }
        if (at_ == At::top) {
            at_ = At::done;
            return true;
        }
        return false;
    }
    bool start_array(std::size_t) override {
        if (skip_ > 0 || unknown_value()) {
            ++skip_;
            return true;
        }
        if (at_ == At::top_value && key_ == "rays") {
            has_rays = true;
            at_ = At::rays;
            return true;
        }
        if (at_ == At::top_value && key_ == "fields") {
            has_fields = true;
            at_ = At::fields;
            return true;
        }
        if (at_ == At::ray_value && (key_ == "origin" || key_ == "direction")) {
            vec_n_ = 0;
            at_ = At::vec;
            return true;
        }
        return false;
    }
    bool end_array() override {
        if (skip_ > 0) return end_skip();
        if (at_ == At::rays || at_ == At::fields) {
            at_ = At::top;
            return true;
        }
        if (at_ == At::vec) {
            if (vec_n_ != 3) return false;
            (key_ == "origin" ? have_origin_ : have_direction_) = true;
            at_ = At::ray;
            return true;
        }
        return false;
    }
    bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override {
        return false;
    }
    bool complete() const { return at_ == At::done; }

private:
    bool is_ray_field() const {
        return key_ == "origin" || key_ == "direction" || key_ == "tmin" || key_ == "tmax";
    }
    /// A value under a key we do not read: skipped, as the DOM reader ignores it.
    bool unknown_value() const {
        if (at_ == At::top_value) {
            return key_ != "rays" && key_ != "fields" && key_ != "mode" && key_ != "precision";
        }
        return at_ == At::ray_value && !is_ray_field();
    }
    bool skip_scalar() {
        if (skip_ > 0) return true;
        if (unknown_value()) {
            at_ = at_ == At::top_value ? At::top : At::ray;
            return true;
        }
        return false;
    }
    bool end_skip() {
        if (--skip_ == 0) at_ = at_ == At::top_value ? At::top : At::ray;
        return true;
    }
    bool number(double v) {
        if (skip_ > 0) return true;
        if (!std::isfinite(v)) return false;
        // Only inside a ray object is there a current ray (a bare number in the rays array, or
        // anywhere else, is not the expected shape).
        if (at_ == At::vec) {
            if (vec_n_ >= 3) return false;
            engine::Ray& r = out_.rays.back();
            (key_ == "origin" ? r.origin : r.direction)[vec_n_++] = v;
            return true;
        }
        if (at_ == At::ray_value) {
            engine::Ray& r = out_.rays.back();
            if (key_ == "tmin") {
                r.tmin = v;
            } else if (key_ == "tmax") {
                r.tmax = v;
            } else if (is_ray_field()) {
                return false;
            }
            at_ = At::ray;
            return true;
        }
        if (unknown_value()) return skip_scalar();
        return false;
    }

    std::size_t max_rays_;
    IntersectRequest& out_;
    At at_ = At::start;
    std::string key_;
    int skip_ = 0;
    std::size_t vec_n_ = 0;
    bool have_origin_ = false, have_direction_ = false;
};

}  // namespace

bool parse_intersect_request_fast(std::string_view body, std::size_t max_rays,
                                  IntersectRequest& out) {
    out.rays.clear();
    Handler h(max_rays, out);
    const bool ok = Json::sax_parse(body.begin(), body.end(), &h, Json::input_format_t::json,
                                    /*strict=*/true);
    if (h.too_many) return false;  // the DOM reader reports too_large with the real count
    if (!ok || !h.complete() || !h.has_rays) return false;
    if (h.has_mode) out.options.mode = parse_mode(h.mode, "/mode");
    if (h.has_precision) out.options.precision = parse_precision(h.precision, "/precision");
    if (h.has_fields) {
        Json f = Json::array();
        for (auto& s : h.fields) f.push_back(std::move(s));
        out.fields = parse_fields(f, "/fields");
    }
    out.options.want_normal = out.fields.normal || out.fields.front_face;
    for (std::size_t i = 0; i < out.rays.size(); ++i) {
        engine::Status st = engine::validate_ray(out.rays[i], i);
        if (!st.ok()) throw from_status(st);
    }
    return true;
}

}  // namespace raycastd::server
