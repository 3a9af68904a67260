#pragma once
// Metrics: the counters behind GET /metrics, written out in the Prometheus text exposition
// format 0.0.4 (https://prometheus.io/docs/instrumenting/exposition_formats/). Every counter is
// a relaxed atomic, so that counting costs a request a few uncontended increments and no lock;
// the set of label values is fixed before serving (routes are added while the App installs
// them, status codes and ray kinds are small closed sets), so a client's paths cannot grow it.
// Figures kept elsewhere (scenes, connections, jobs, memory) are asked for at scrape time
// through gauges registered beside the routes.

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <string>
#include <vector>

#include "engine/points/point_queries.h"
#include "engine/query_types.h"
#include "server/api_error.h"

namespace raycastd::server {

/// What a traced ray was for: a query mode of the intersect routes, or its role in a render or
/// ray tree (camera rays, shadow rays, and the two kinds of secondary rays).
enum class RayKind { closest, any, all, count, primary, shadow, reflected, refracted };

/// The RayKind of an intersect query's mode.
RayKind ray_kind(engine::Mode mode);

/// A histogram with fixed bucket bounds (seconds): counts per bucket, their sum and count.
class Histogram {
  public:
    /// Latency bounds from 0.5 ms to a minute: a small query takes well under a millisecond
    /// here, a large render or scene build tens of seconds.
    static constexpr std::array<double, 16> kBounds = {
        0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60};

    void observe(double seconds);
    /// Appends the _bucket, _sum and _count lines of `name` with `labels` (`a="b",` or empty).
    void write(std::string& out, const std::string& name, const std::string& labels) const;

  private:
    std::array<std::atomic<std::uint64_t>, kBounds.size() + 1> buckets_{};  ///< last: +Inf
    std::atomic<std::uint64_t> sum_ns_{0};  ///< nanoseconds: an atomic double needs a CAS loop
};

class Metrics {
  public:
    static constexpr int kMinStatus = 100, kMaxStatus = 599;

    Metrics();
    Metrics(const Metrics&) = delete;
    Metrics& operator=(const Metrics&) = delete;

    /// The route index for `method` and a route pattern (cpp-httplib's regex, written out as a
    /// label with "{id}" for an id group and "{path}" for a final "(.*)"). Call before serving:
    /// routes are not guarded by a lock. Index 0 is "unmatched" (no route: 404, 405) of a
    /// method outside kUnmatchedMethods (or none: a request line httplib could not read).
    std::size_t add_route(const std::string& method, const std::string& pattern);
    /// The methods whose unmatched requests are counted apart, under their own name; any other
    /// is "other" (route 0). A fixed list: a client's own text as a label would make a new series
    /// with every method it invents. HEAD counts with GET, as on the routes.
    static constexpr std::array<const char*, 6> kUnmatchedMethods = {"GET",    "POST",  "PUT",
                                                                     "DELETE", "PATCH", "OPTIONS"};
    /// The "unmatched" route index `method` is counted under.
    std::size_t unmatched_route(const std::string& method) const;
    /// The label a route pattern is reported under ("/v1/scenes/{id}/intersect").
    static std::string route_label(const std::string& pattern);
    const std::string& route_name(std::size_t route) const;

    /// One answered request: its route index, HTTP status and time from head to last byte.
    void observe_request(std::size_t route, int status, double seconds);
    void count_rays(RayKind kind, engine::Precision precision, std::uint64_t n);
    /// Points answered by the points routes, by query.
    void count_points(engine::PointQuery query, std::uint64_t n);
    /// An API error answered (by code): busy and timeout among them.
    void count_error(ErrorCode code);
    /// The API errors answered with `code` so far.
    std::uint64_t errors(ErrorCode code) const;
    /// A scene built (registered, or rebuilt from the data dir after eviction or on another
    /// replica's scene): loading, the BVH and the rest of its preparation.
    void observe_scene_build(double seconds);

    /// A figure read at scrape time: `type` is "gauge" or "counter".
    void add_gauge(std::string name, std::string type, std::string help,
                   std::function<double()> read);

    /// The whole exposition (text/plain; version=0.0.4).
    std::string render() const;
    static constexpr const char* kContentType = "text/plain; version=0.0.4; charset=utf-8";

  private:
    struct Route {
        std::string method, label;
        std::array<std::atomic<std::uint64_t>, kMaxStatus - kMinStatus + 1> by_status{};
        Histogram latency;
    };
    struct Gauge {
        std::string name, type, help;
        std::function<double()> read;
    };
    static constexpr std::size_t kRayKinds = 8, kPrecisions = 3, kPointQueries = 4;
    static constexpr std::size_t kErrorCodes = static_cast<std::size_t>(ErrorCode::internal) + 1;

    std::deque<Route> routes_;  ///< a deque: entries never move once added
    std::array<std::atomic<std::uint64_t>, kRayKinds * kPrecisions> rays_{};
    std::array<std::atomic<std::uint64_t>, kPointQueries> points_{};
    std::array<std::atomic<std::uint64_t>, kErrorCodes> errors_{};
    Histogram scene_build_;
    std::vector<Gauge> gauges_;
};

}  // namespace raycastd::server
