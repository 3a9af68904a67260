// The answer and job-image budgets against the real binary (server/memory_budget.h): an answer
// held by a client that does not read it counts against --answer-budget-mb until it has been
// written, a large answer that would take the budget over is 503 busy with Retry-After, small
// answers are always served, and finished async images past --job-budget-mb forget the oldest
// job. GET /metrics shows the budgets and what they hold.

#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/socket.h>

#include "tests/support/raw_http.h"
#include "tests/support/server_process.h"

namespace raycastd {
namespace {

using Json = nlohmann::json;
using namespace std::chrono_literals;
using testing::ServerProcess;

const char* kScene = R"({"objects":[{"type":"sphere","center":[0,0,0],"radius":1}]})";

std::string register_scene(const ServerProcess& server) {
    auto res = server.client()->Post("/v1/scenes", kScene, "application/json");
    EXPECT_TRUE(res);
    if (!res)
        return "";
    EXPECT_TRUE(res->status == 200 || res->status == 201) << res->body;
    return Json::parse(res->body).at("id").get<std::string>();
}

/// n float32 ray records from z = −5 towards the sphere (every one a hit).
std::string ray_records(std::size_t n) {
    const float r[8] = {0, 0, -5, 0, 0, 1, 0, std::numeric_limits<float>::infinity()};
    std::string body(n * sizeof r, '\0');
    for (std::size_t i = 0; i < n; ++i)
        std::memcpy(body.data() + i * sizeof r, r, sizeof r);
    return body;
}

std::string binary_request(const std::string& id, const std::string& records) {
    return "POST /v1/scenes/" + id +
           "/intersect?mode=closest&dtype=float32 HTTP/1.1\r\nHost: x\r\n"
           "Content-Type: application/octet-stream\r\nContent-Length: " +
           std::to_string(records.size()) + "\r\n\r\n" + records;
}

/// The value of `series` in a scrape of GET /metrics; −1 when it is absent.
double metric(const ServerProcess& server, const std::string& series) {
    auto res = server.client()->Get("/metrics");
    if (!res || res->status != 200)
        return -1;
    const std::string text = "\n" + res->body;
    const std::size_t at = text.find("\n" + series + " ");
    return at == std::string::npos ? -1 : std::stod(text.substr(at + series.size() + 2));
}

/// Polls `series` (every 20 ms, for up to 30 s) until `done` says yes; its last value.
template <class Done>
double wait_for_metric(const ServerProcess& server, const std::string& series, Done done) {
    double v = metric(server, series);
    for (int i = 0; i < 1500 && !done(v); ++i) {
        std::this_thread::sleep_for(20ms);
        v = metric(server, series);
    }
    return v;
}

TEST(Budget, AnAnswerOverTheAnswerBudgetIsBusyUntilTheHeldOneIsWritten) {
    ServerProcess server({"--answer-budget-mb", "4"});
    const std::string id = register_scene(server);
    EXPECT_EQ(metric(server, "raycastd_answer_budget_bytes"), 4 << 20);
    EXPECT_EQ(metric(server, "raycastd_answer_bytes"), 0);

    // A client that asks for 19 MB of answer and reads none of it: alone, it is admitted (over
    // the budget), and its answer stays charged while the server waits to write it (a small
    // receive window, and the server's send buffer holds at most 4 MB: tcp_wmem).
    const std::size_t held_rays = 600'000;
    const int slow = ::socket(AF_INET, SOCK_STREAM, 0);
    const int window = 4096;
    ::setsockopt(slow, SOL_SOCKET, SO_RCVBUF, &window, sizeof window);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(server.port()));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::connect(slow, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    testing::send_all(slow, binary_request(id, ray_records(held_rays)));
    const double held = wait_for_metric(server, "raycastd_answer_bytes",
                                        [&](double v) { return v >= held_rays * 32.0; });
    ASSERT_EQ(held, held_rays * 32.0) << "the held answer is charged at its size";

    // A second large answer (320 KB) does not fit beside it: 503 busy, Retry-After, before any
    // of its work.
    const std::string busy =
        testing::exchange(server.port(), binary_request(id, ray_records(10'000)), 30s);
    EXPECT_EQ(testing::status_of(busy), 503) << busy.substr(0, 300);
    EXPECT_NE(busy.find("Retry-After: 1"), std::string::npos) << busy.substr(0, 300);
    const Json err = Json::parse(testing::body_of(busy)).at("error");
    EXPECT_EQ(err.at("code"), "busy");
    EXPECT_NE(err.at("message").get<std::string>().find("--answer-budget-mb"), std::string::npos);
    // So is a large JSON answer (charged on its estimate before the work).
    Json many = {{"rays", Json::array()}};
    for (int i = 0; i < 1000; ++i)
        many["rays"].push_back({{"origin", {0, 0, -5}}, {"direction", {0, 0, 1}}});
    auto json_busy =
        server.client()->Post("/v1/scenes/" + id + "/intersect", many.dump(), "application/json");
    ASSERT_TRUE(json_busy);
    EXPECT_EQ(json_busy->status, 503) << json_busy->body;
    EXPECT_EQ(json_busy->get_header_value("Retry-After"), "1");
    // Small answers are never refused.
    const Json one = {{"rays", {{{"origin", {0, 0, -5}}, {"direction", {0, 0, 1}}}}}};
    auto small =
        server.client()->Post("/v1/scenes/" + id + "/intersect", one.dump(), "application/json");
    ASSERT_TRUE(small);
    EXPECT_EQ(small->status, 200) << small->body;
    EXPECT_GE(metric(server, "raycastd_busy_rejections_total"), 2);

    // The slow client goes: its answer's charge is given back, and the large answer fits.
    ::close(slow);
    EXPECT_EQ(wait_for_metric(server, "raycastd_answer_bytes", [](double v) { return v == 0; }), 0);
    const std::string ok =
        testing::exchange(server.port(), binary_request(id, ray_records(10'000)), 30s);
    EXPECT_EQ(testing::status_of(ok), 200) << ok.substr(0, 300);
    EXPECT_EQ(testing::body_of(ok).size(), 10'000u * 32);
    // Released once written: the client can hold the last byte before the server's writer has
    // returned and given the charge back, so the scrape waits for it (one scrape failed 6 or more
    // runs of 40).
    EXPECT_EQ(wait_for_metric(server, "raycastd_answer_bytes", [](double v) { return v == 0; }), 0)
        << "released once written";
}

TEST(Budget, FinishedJobImagesOverTheJobBudgetForgetTheOldest) {
    // A budget of 0: only the newest finished image is kept.
    ServerProcess server({"--job-budget-mb", "0"});
    const std::string id = register_scene(server);
    auto c = server.client();
    const Json body = {{"width", 64}, {"height", 64}, {"async", true}};
    std::vector<std::string> jobs;
    for (int i = 0; i < 2; ++i) {
        auto res = c->Post("/v1/scenes/" + id + "/render", body.dump(), "application/json");
        ASSERT_TRUE(res);
        ASSERT_EQ(res->status, 202) << res->body;
        jobs.push_back(Json::parse(res->body).at("job").get<std::string>());
    }
    // Jobs run in order: once the second is done, the first has finished before it.
    std::string state;
    for (int i = 0; i < 1500 && state != "done"; ++i) {
        auto res = c->Get("/v1/jobs/" + jobs[1]);
        ASSERT_TRUE(res);
        state = Json::parse(res->body).at("state").get<std::string>();
        if (state != "done")
            std::this_thread::sleep_for(20ms);
    }
    ASSERT_EQ(state, "done");
    auto first = c->Get("/v1/jobs/" + jobs[0] + "/image");
    ASSERT_TRUE(first);
    EXPECT_EQ(first->status, 404) << first->body;
    EXPECT_EQ(Json::parse(first->body).at("error").at("code"), "job_not_found");
    auto second = c->Get("/v1/jobs/" + jobs[1] + "/image");
    ASSERT_TRUE(second);
    EXPECT_EQ(second->status, 200);
    EXPECT_EQ(second->get_header_value("Content-Type"), "image/png");
    EXPECT_EQ(metric(server, "raycastd_jobs_evicted_total"), 1);
    EXPECT_EQ(metric(server, "raycastd_job_image_bytes"), static_cast<double>(second->body.size()));
    EXPECT_EQ(metric(server, "raycastd_job_budget_bytes"), 0);
}

}  // namespace
}  // namespace raycastd
