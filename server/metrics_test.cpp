#include "server/metrics.h"

#include <gtest/gtest.h>

#include "engine/process_memory.h"
#include "server/request_log.h"

namespace raycastd::server {
namespace {

/// The value of the sample line that starts with `series` ("name{labels}"), or -1.
double sample(const std::string& text, const std::string& series) {
    const std::size_t at = text.find("\n" + series + " ");
    if (at == std::string::npos)
        return -1;
    return std::stod(text.substr(at + series.size() + 2));
}

TEST(Metrics, RouteLabelsArePatternsNotPaths) {
    EXPECT_EQ(Metrics::route_label(R"(/v1/scenes/([A-Za-z0-9_]+)/intersect)"),
              "/v1/scenes/{id}/intersect");
    EXPECT_EQ(Metrics::route_label("/static/(.*)"), "/static/{path}");
    EXPECT_EQ(Metrics::route_label("/v1/health"), "/v1/health");
}

TEST(Metrics, CountsRequestsByRouteAndStatus) {
    Metrics m;
    const std::size_t get = m.add_route("GET", R"(/v1/scenes/([A-Za-z0-9_]+))");
    m.observe_request(get, 200, 0.0002);
    m.observe_request(get, 200, 0.003);
    m.observe_request(get, 404, 0.02);
    m.observe_request(0, 404, 0.0);
    const std::string t = m.render();
    const std::string route = R"(method="GET",route="/v1/scenes/{id}")";
    EXPECT_EQ(sample(t, "raycastd_http_requests_total{" + route + R"(,status="200"})"), 2);
    EXPECT_EQ(sample(t, "raycastd_http_requests_total{" + route + R"(,status="404"})"), 1);
    EXPECT_EQ(
        sample(t, R"(raycastd_http_requests_total{method="other",route="unmatched",status="404"})"),
        1);
    // Cumulative buckets: 0.0002 ≤ 0.0005; 0.003 ≤ 0.005; 0.02 ≤ 0.025.
    const std::string h = "raycastd_http_request_duration_seconds";
    EXPECT_EQ(sample(t, h + "_bucket{" + route + R"(,le="0.0005"})"), 1);
    EXPECT_EQ(sample(t, h + "_bucket{" + route + R"(,le="0.005"})"), 2);
    EXPECT_EQ(sample(t, h + "_bucket{" + route + R"(,le="0.025"})"), 3);
    EXPECT_EQ(sample(t, h + "_bucket{" + route + R"(,le="+Inf"})"), 3);
    EXPECT_EQ(sample(t, h + "_count{" + route + "}"), 3);
    EXPECT_NEAR(sample(t, h + "_sum{" + route + "}"), 0.0232, 1e-6);
    // A status the table does not know is clamped into range, not dropped.
    m.observe_request(get, 999, 0.0);
    EXPECT_EQ(sample(m.render(), "raycastd_http_requests_total{" + route + R"(,status="599"})"), 1);
}

TEST(Metrics, UnmatchedRoutesAreAFixedSetOfMethods) {
    Metrics m;
    EXPECT_EQ(m.unmatched_route("BREW"), 0u);
    EXPECT_EQ(m.unmatched_route(""), 0u);
    EXPECT_EQ(m.unmatched_route("HEAD"), m.unmatched_route("GET"));
    EXPECT_NE(m.unmatched_route("GET"), m.unmatched_route("POST"));
    for (const char* method : Metrics::kUnmatchedMethods) {
        const std::size_t r = m.unmatched_route(method);
        EXPECT_NE(r, 0u) << method;
        EXPECT_EQ(m.route_name(r), "unmatched");
        m.observe_request(r, 405, 0.0);
    }
    const std::string t = m.render();
    EXPECT_EQ(
        sample(t,
               R"(raycastd_http_requests_total{method="DELETE",route="unmatched",status="405"})"),
        1);
    EXPECT_EQ(
        sample(t,
               R"(raycastd_http_requests_total{method="OPTIONS",route="unmatched",status="405"})"),
        1);
}

TEST(Metrics, RaysErrorsAndGauges) {
    Metrics m;
    m.count_rays(RayKind::closest, engine::Precision::refined, 1000);
    m.count_rays(ray_kind(engine::Mode::count), engine::Precision::exact, 7);
    m.count_error(ErrorCode::busy);
    m.count_error(ErrorCode::busy);
    m.observe_scene_build(0.3);
    double level = 4;
    m.add_gauge("raycastd_test_level", "gauge", "A test gauge.", [&] { return level; });
    std::string t = m.render();
    EXPECT_EQ(sample(t, R"(raycastd_rays_total{kind="closest",precision="refined"})"), 1000);
    EXPECT_EQ(sample(t, R"(raycastd_rays_total{kind="count",precision="exact"})"), 7);
    EXPECT_EQ(sample(t, R"(raycastd_rays_total{kind="shadow",precision="fast"})"), 0);
    EXPECT_EQ(sample(t, R"(raycastd_api_errors_total{code="busy"})"), 2);
    EXPECT_EQ(m.errors(ErrorCode::busy), 2u);
    EXPECT_EQ(sample(t, R"(raycastd_scene_build_seconds_bucket{le="0.25"})"), 0);
    EXPECT_EQ(sample(t, R"(raycastd_scene_build_seconds_bucket{le="0.5"})"), 1);
    EXPECT_EQ(sample(t, "raycastd_scene_build_seconds_count"), 1);
    EXPECT_EQ(sample(t, "raycastd_test_level"), 4);
    EXPECT_NE(t.find("# TYPE raycastd_test_level gauge\n"), std::string::npos);
    level = 2.5;  // read at scrape time
    EXPECT_EQ(sample(m.render(), "raycastd_test_level"), 2.5);
}

TEST(Metrics, ResidentMemoryIsReadFromProc) {
    // A running test binary holds at least a megabyte resident.
    EXPECT_GT(engine::process_resident_bytes(), 1u << 20);
}

TEST(RequestLog, LinesAreJsonWithTheRequestId) {
    RequestLogEntry e;
    e.request_id = "rq_7";
    e.method = "POST";
    e.route = "/v1/scenes/{id}/intersect";
    e.path = "/v1/scenes/sc_1/intersect";
    e.status = 200;
    e.duration_ms = 1.25;
    e.rays = 42;
    const std::string info = request_log_line(e, LogLevel::info);
    EXPECT_EQ(info.front(), '{');
    EXPECT_EQ(info.back(), '}');
    EXPECT_NE(info.find(R"("request_id":"rq_7")"), std::string::npos) << info;
    EXPECT_NE(info.find(R"("route":"/v1/scenes/{id}/intersect")"), std::string::npos);
    EXPECT_NE(info.find(R"("status":200)"), std::string::npos);
    EXPECT_NE(info.find(R"("duration_ms":1.250)"), std::string::npos);
    EXPECT_NE(info.find(R"("rays":42)"), std::string::npos);
    EXPECT_EQ(info.find("sc_1"), std::string::npos);  // the raw path only at debug
    EXPECT_NE(request_log_line(e, LogLevel::debug).find(R"("path":"/v1/scenes/sc_1/intersect")"),
              std::string::npos);
    EXPECT_TRUE(logs_request(LogLevel::info, 200));
    EXPECT_FALSE(logs_request(LogLevel::warn, 404));
    EXPECT_TRUE(logs_request(LogLevel::warn, 503));
    EXPECT_FALSE(logs_request(LogLevel::error, 503));
    EXPECT_EQ(parse_log_level("debug"), LogLevel::debug);
    EXPECT_FALSE(parse_log_level("loud"));
}

TEST(RequestLog, RaysCountOnlyInsideARequest) {
    Metrics m;
    note_rays(RayKind::any, engine::Precision::fast, 5);  // no request open: nothing
    RequestRecord& r = current_request();
    r = RequestRecord{};
    r.open = true;
    r.metrics = &m;
    note_rays(RayKind::any, engine::Precision::fast, 5);
    note_rays(m, RayKind::primary, engine::Precision::exact, 3);
    EXPECT_EQ(r.rays, 8u);
    r = RequestRecord{};
    const std::string t = m.render();
    EXPECT_EQ(sample(t, R"(raycastd_rays_total{kind="any",precision="fast"})"), 5);
    EXPECT_EQ(sample(t, R"(raycastd_rays_total{kind="primary",precision="exact"})"), 3);
}

}  // namespace
}  // namespace raycastd::server
