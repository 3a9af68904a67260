#include "server/metrics.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace raycastd::server {

namespace {

constexpr auto kRelaxed = std::memory_order_relaxed;

constexpr const char* kRayKindNames[] = {"closest", "any",    "all",       "count",
                                         "primary", "shadow", "reflected", "refracted"};

/// A sample value as the format writes it: integers exactly, others in the fewest digits that
/// read back as the same double (0.0005, not 0.00050000000000000001), and the spellings the
/// format gives the non-finite values.
std::string number(double v) {
    if (std::isnan(v))
        return "NaN";
    if (std::isinf(v))
        return v > 0 ? "+Inf" : "-Inf";
    char buf[32];
    if (v == std::floor(v) && std::fabs(v) < 9e15) {
        std::snprintf(buf, sizeof buf, "%.0f", v);
        return buf;
    }
    for (int digits = 1; digits <= 17; ++digits) {
        std::snprintf(buf, sizeof buf, "%.*g", digits, v);
        if (std::strtod(buf, nullptr) == v)
            break;
    }
    return buf;
}

/// A label value with the format's three escapes (backslash, double quote, newline).
std::string escape(const std::string& s) {
    std::string out;
    for (char c : s) {
        if (c == '\\' || c == '"') {
            out += '\\';
            out += c;
        } else if (c == '\n') {
            out += "\\n";
        } else {
            out += c;
        }
    }
    return out;
}

void header(std::string& out, const char* name, const char* type, const char* help) {
    out += "# HELP ";
    out += name;
    out += ' ';
    out += help;
    out += "\n# TYPE ";
    out += name;
    out += ' ';
    out += type;
    out += '\n';
}

}  // namespace

RayKind ray_kind(engine::Mode mode) {
    switch (mode) {
        case engine::Mode::closest:
            return RayKind::closest;
        case engine::Mode::any:
            return RayKind::any;
        case engine::Mode::all:
            return RayKind::all;
        case engine::Mode::count:
            return RayKind::count;
    }
    return RayKind::closest;
}

void Histogram::observe(double seconds) {
    std::size_t b = 0;
    while (b < kBounds.size() && seconds > kBounds[b])
        ++b;
    buckets_[b].fetch_add(1, kRelaxed);
    sum_ns_.fetch_add(static_cast<std::uint64_t>(std::max(0.0, seconds) * 1e9), kRelaxed);
}

void Histogram::write(std::string& out, const std::string& name, const std::string& labels) const {
    // Buckets are cumulative in the format: each counts the observations at or below its bound.
    // Read without a lock, a scrape may see a bucket ahead of the count by a request in flight;
    // there is no separate count: it is the +Inf bucket's total, so the two always agree.
    std::uint64_t cumulative = 0;
    for (std::size_t b = 0; b <= kBounds.size(); ++b) {
        cumulative += buckets_[b].load(kRelaxed);
        const std::string le = b < kBounds.size() ? number(kBounds[b]) : "+Inf";
        out +=
            name + "_bucket{" + labels + "le=\"" + le + "\"} " + std::to_string(cumulative) + "\n";
    }
    const std::string plain = labels.empty() ? "" : "{" + labels.substr(0, labels.size() - 1) + "}";
    out += name + "_sum" + plain + " " + number(static_cast<double>(sum_ns_.load(kRelaxed)) / 1e9) +
           "\n";
    out += name + "_count" + plain + " " + std::to_string(cumulative) + "\n";
}

Metrics::Metrics() {
    add_route("other", "unmatched");
    for (const char* method : kUnmatchedMethods)
        add_route(method, "unmatched");
}

std::size_t Metrics::unmatched_route(const std::string& method) const {
    const std::string m = method == "HEAD" ? "GET" : method;
    for (std::size_t i = 0; i < kUnmatchedMethods.size(); ++i) {
        if (m == kUnmatchedMethods[i])
            return i + 1;  // after route 0, in the constructor's order
    }
    return 0;
}

std::string Metrics::route_label(const std::string& pattern) {
    constexpr std::string_view kId = "([A-Za-z0-9_]+)", kRest = "(.*)";
    std::string out;
    for (std::size_t i = 0; i < pattern.size();) {
        if (pattern.compare(i, kId.size(), kId) == 0) {
            out += "{id}";
            i += kId.size();
        } else if (pattern.compare(i, kRest.size(), kRest) == 0) {
            out += "{path}";
            i += kRest.size();
        } else {
            out += pattern[i++];
        }
    }
    return out;
}

std::size_t Metrics::add_route(const std::string& method, const std::string& pattern) {
    Route& r = routes_.emplace_back();
    r.method = method;
    r.label = route_label(pattern);
    return routes_.size() - 1;
}

const std::string& Metrics::route_name(std::size_t route) const {
    return routes_.at(route < routes_.size() ? route : 0).label;
}

void Metrics::observe_request(std::size_t route, int status, double seconds) {
    Route& r = routes_[route < routes_.size() ? route : 0];
    const int s = std::min(std::max(status, kMinStatus), kMaxStatus);
    r.by_status[static_cast<std::size_t>(s - kMinStatus)].fetch_add(1, kRelaxed);
    r.latency.observe(seconds);
}

void Metrics::count_rays(RayKind kind, engine::Precision precision, std::uint64_t n) {
    const auto k = static_cast<std::size_t>(kind), p = static_cast<std::size_t>(precision);
    rays_[k * kPrecisions + p].fetch_add(n, kRelaxed);
}

void Metrics::count_points(engine::PointQuery query, std::uint64_t n) {
    points_[static_cast<std::size_t>(query)].fetch_add(n, kRelaxed);
}

void Metrics::count_error(ErrorCode code) {
    errors_[static_cast<std::size_t>(code)].fetch_add(1, kRelaxed);
}

std::uint64_t Metrics::errors(ErrorCode code) const {
    return errors_[static_cast<std::size_t>(code)].load(kRelaxed);
}

void Metrics::observe_scene_build(double seconds) {
    scene_build_.observe(seconds);
}

void Metrics::add_gauge(std::string name, std::string type, std::string help,
                        std::function<double()> read) {
    gauges_.push_back({std::move(name), std::move(type), std::move(help), std::move(read)});
}

std::string Metrics::render() const {
    std::string out;
    out.reserve(32 << 10);
    header(out, "raycastd_http_requests_total", "counter",
           "Requests answered, by method, route pattern and HTTP status (HEAD counts with GET).");
    for (const Route& r : routes_) {
        const std::string labels =
            "method=\"" + escape(r.method) + "\",route=\"" + escape(r.label) + "\",status=\"";
        for (int s = kMinStatus; s <= kMaxStatus; ++s) {
            const auto n = r.by_status[static_cast<std::size_t>(s - kMinStatus)].load(kRelaxed);
            if (n > 0) {
                out += "raycastd_http_requests_total{" + labels + std::to_string(s) + "\"} " +
                       std::to_string(n) + "\n";
            }
        }
    }
    header(out, "raycastd_http_request_duration_seconds", "histogram",
           "Time from a request's head to its answer's last byte, by route pattern.");
    for (const Route& r : routes_) {
        r.latency.write(out, "raycastd_http_request_duration_seconds",
                        "method=\"" + escape(r.method) + "\",route=\"" + escape(r.label) + "\",");
    }
    header(out, "raycastd_rays_total", "counter",
           "Rays traced: intersect queries by mode, renders and ray trees by role; by the "
           "precision that answered.");
    for (std::size_t k = 0; k < kRayKinds; ++k) {
        for (std::size_t p = 0; p < kPrecisions; ++p) {
            out += std::string("raycastd_rays_total{kind=\"") + kRayKindNames[k] +
                   "\",precision=\"" + engine::to_string(static_cast<engine::Precision>(p)) +
                   "\"} " + std::to_string(rays_[k * kPrecisions + p].load(kRelaxed)) + "\n";
        }
    }
    header(out, "raycastd_points_total", "counter",
           "Points answered by the points routes, by query.");
    for (std::size_t q = 0; q < kPointQueries; ++q) {
        out += std::string("raycastd_points_total{query=\"") +
               engine::to_string(static_cast<engine::PointQuery>(q)) + "\"} " +
               std::to_string(points_[q].load(kRelaxed)) + "\n";
    }
    header(out, "raycastd_api_errors_total", "counter",
           "Error answers by API error code (docs/api.md).");
    for (std::size_t c = 0; c < kErrorCodes; ++c) {
        out += "raycastd_api_errors_total{code=\"" +
               std::string(to_string(static_cast<ErrorCode>(c))) + "\"} " +
               std::to_string(errors_[c].load(kRelaxed)) + "\n";
    }
    header(out, "raycastd_scene_build_seconds", "histogram",
           "Scene builds for the registry (loading and BVH), on registration and on reloading "
           "a saved scene.");
    scene_build_.write(out, "raycastd_scene_build_seconds", "");
    for (const Gauge& g : gauges_) {
        header(out, g.name.c_str(), g.type.c_str(), g.help.c_str());
        out += g.name + " " + number(g.read()) + "\n";
    }
    return out;
}

}  // namespace raycastd::server
