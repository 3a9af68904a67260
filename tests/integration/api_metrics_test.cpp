// GET /metrics against the real binary: the counters move with the requests served (by route
// pattern, status, ray kind and precision), the exposition has the Prometheus 0.0.4 content
// type, and a client's paths do not become labels.

#include <chrono>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/server_process.h"

namespace raycastd {
namespace {

using Json = nlohmann::json;

const char* kScene = R"({"objects":[{"type":"sphere","center":[0,0,10],"radius":2},
    {"type":"sphere","center":[0,3,8],"radius":2}],
    "lights":[{"type":"point","position":[5,5,0],"intensity":[1,1,1]}]})";

/// The value of the series `series` ("name{labels}") in a scrape; 0 when it is absent (a
/// counter not yet moved is not written for requests).
double sample(const std::string& scrape, const std::string& series) {
    const std::size_t at = scrape.find("\n" + series + " ");
    return at == std::string::npos ? 0.0 : std::stod(scrape.substr(at + series.size() + 2));
}

struct Metrics : ::testing::Test {
    testing::ServerProcess server;
    std::string scrape() {
        auto res = server.client()->Get("/metrics");
        EXPECT_TRUE(res);
        if (!res)
            return {};
        EXPECT_EQ(res->status, 200);
        EXPECT_EQ(res->get_header_value("Content-Type"),
                  "text/plain; version=0.0.4; charset=utf-8");
        return "\n" + res->body;
    }
};

TEST_F(Metrics, CountersMoveWithTheRequestsServed) {
    auto c = server.client();
    auto added = c->Post("/v1/scenes", kScene, "application/json");
    ASSERT_TRUE(added);
    ASSERT_EQ(added->status, 201) << added->body;
    const std::string id = Json::parse(added->body).at("id");
    const std::string before = scrape();
    EXPECT_EQ(sample(before, "raycastd_scenes_registered"), 1);
    EXPECT_EQ(sample(before, "raycastd_scene_build_seconds_count"), 1);
    EXPECT_GT(sample(before, "process_resident_memory_bytes"), 1 << 20);

    const Json rays = {{"rays",
                        {{{"origin", {0, 0, 0}}, {"direction", {0, 0, 1}}},
                         {{"origin", {0, 0, 0}}, {"direction", {0, 1, 0}}},
                         {{"origin", {0, 0, 0}}, {"direction", {0, 0.3, 1}}}}},
                       {"precision", "exact"}};
    for (int i = 0; i < 2; ++i) {
        auto r =
            c->Post(("/v1/scenes/" + id + "/intersect").c_str(), rays.dump(), "application/json");
        ASSERT_TRUE(r);
        ASSERT_EQ(r->status, 200) << r->body;
    }
    auto render = c->Post(("/v1/scenes/" + id + "/render").c_str(),
                          R"({"width":8,"height":4,"precision":"refined"})", "application/json");
    ASSERT_TRUE(render);
    ASSERT_EQ(render->status, 200) << render->body;
    const Json points = {{"points", {{0, 0, 0}, {0, 0, 20}}}, {"query", "signed_distance"}};
    auto pts = c->Post(("/v1/scenes/" + id + "/points").c_str(), points.dump(), "application/json");
    ASSERT_TRUE(pts);
    ASSERT_EQ(pts->status, 200) << pts->body;
    auto missing = c->Post("/v1/scenes/sc_nosuchscene/intersect", rays.dump(), "application/json");
    ASSERT_TRUE(missing);
    EXPECT_EQ(missing->status, 404);

    // A request is counted once its answer has been written, so the client may see the answer
    // a moment before the counters move: the scrape is repeated until the last one is counted.
    // Both its counters are waited for: a scrape is no snapshot, and one read the status counter
    // before the 404's increment and the histogram after it (asan CI, 2026-12-07).
    const std::string intersect = R"(method="POST",route="/v1/scenes/{id}/intersect")";
    auto counted = [&](const std::string& text) {
        return sample(text, "raycastd_http_request_duration_seconds_count{" + intersect + "}") >=
                   3 &&
               sample(text, "raycastd_http_requests_total{" + intersect + R"(,status="404"})") >= 1;
    };
    std::string after = scrape();
    for (int i = 0; i < 100 && !counted(after); ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        after = scrape();
    }
    EXPECT_EQ(sample(after, "raycastd_http_requests_total{" + intersect + R"(,status="200"})"), 2);
    EXPECT_EQ(sample(after, "raycastd_http_requests_total{" + intersect + R"(,status="404"})"), 1);
    EXPECT_EQ(sample(after, "raycastd_http_request_duration_seconds_count{" + intersect + "}"), 3);
    EXPECT_GT(sample(after, "raycastd_http_request_duration_seconds_sum{" + intersect + "}"), 0);
    EXPECT_EQ(sample(after, R"(raycastd_rays_total{kind="closest",precision="exact"})") -
                  sample(before, R"(raycastd_rays_total{kind="closest",precision="exact"})"),
              6);
    // 8 × 4 camera rays at 1 sample per pixel, and shadow rays toward the light for the hits,
    // counted under the path that answered: exact, for a scene this small (API.md).
    EXPECT_EQ(sample(after, R"(raycastd_rays_total{kind="primary",precision="exact"})"), 32);
    EXPECT_EQ(sample(after, R"(raycastd_api_errors_total{code="scene_not_found"})"), 1);
    EXPECT_EQ(sample(after, R"(raycastd_points_total{query="signed_distance"})"), 2);
    EXPECT_EQ(sample(after, R"(raycastd_points_total{query="closest"})"), 0);
    // The route is the pattern: the id asked for appears nowhere in the scrape.
    EXPECT_EQ(after.find("sc_nosuchscene"), std::string::npos);
    EXPECT_EQ(after.find(id), std::string::npos);
    // The scrapes before this one (at least the first); this one is counted once written.
    EXPECT_GE(sample(after,
                     R"(raycastd_http_requests_total{method="GET",route="/metrics",status="200"})"),
              1);
}

TEST_F(Metrics, UnmatchedRequestsAreCountedByAKnownMethodOrOther) {
    // A path no route serves, by a method the server knows, by HEAD (counted with GET), and by
    // methods it does not (which cpp-httplib answers 400 before routing): those share "other",
    // so a client inventing methods makes no series.
    auto c = server.client();
    ASSERT_TRUE(c->Get("/v1/nothing-here"));
    ASSERT_TRUE(c->Head("/v1/nothing-here"));
    ASSERT_TRUE(c->Patch("/v1/nothing-here", "{}", "application/json"));
    for (const char* method : {"BREW", "PROPFIND"}) {
        httplib::Request req;
        req.method = method;
        req.path = "/v1/nothing-here";
        ASSERT_TRUE(c->send(req));
    }
    const auto unmatched = [](const char* method, const char* status = "404") {
        return std::string(R"(raycastd_http_requests_total{method=")") + method +
               R"(",route="unmatched",status=")" + status + "\"}";
    };
    // Each is counted once its answer is written, and the 400s on connections of their own:
    // the scrape is repeated until all five are.
    const auto counted = [&](const std::string& scrape) {
        return sample(scrape, unmatched("other", "400")) + sample(scrape, unmatched("GET")) +
               sample(scrape, unmatched("PATCH"));
    };
    std::string after = scrape();
    for (int i = 0; i < 100 && counted(after) < 5; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        after = scrape();
    }
    EXPECT_EQ(sample(after, unmatched("GET")), 2);
    EXPECT_EQ(sample(after, unmatched("PATCH")), 1);
    EXPECT_EQ(sample(after, unmatched("other", "400")), 2);
    EXPECT_EQ(after.find("BREW"), std::string::npos);
    EXPECT_EQ(after.find("PROPFIND"), std::string::npos);
    EXPECT_EQ(after.find(R"(method="")"), std::string::npos);
}

}  // namespace
}  // namespace raycastd
