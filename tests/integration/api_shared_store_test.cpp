// Two raycastd processes sharing one --data-dir, as replicas behind a balancer do: they race to
// register the same scenes, every post succeeds and exactly one per scene says 201, the saved
// copies are whole, and both (and a third started afterwards) answer every id identically,
// including ids only the other one was sent.

#include <filesystem>
#include <set>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "tests/support/server_process.h"

namespace raycastd {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

/// A scene of `n` spheres along a line, different for each `seed` (large enough that builds
/// and writes overlap when two servers get it at once).
std::string scene(int seed, int n = 400) {
    Json objects = Json::array();
    for (int i = 0; i < n; ++i) {
        objects.push_back({{"type", "sphere"},
                           {"center", {0.01 * i, 0.1 * seed, 10.0 + 0.05 * i}},
                           {"radius", 0.5}});
    }
    return Json{{"objects", objects}}.dump();
}

const std::string kRays = Json{
    {"rays",
     {{{"origin", {0, 0, 0}}, {"direction", {0, 0, 1}}},
      {{"origin", {0, 0.3, 0}}, {"direction", {0.01, 0, 1}}},
      {{"origin", {1, 0, 0}}, {"direction", {0, 0.01, 1}}}}},
    {"precision", "exact"}}.dump();

struct SharedStore : ::testing::Test {
    fs::path data = fs::temp_directory_path() / ("raycastd_shared_" + std::to_string(::getpid()));
    void SetUp() override { fs::remove_all(data); }
    void TearDown() override { fs::remove_all(data); }
    // More connection threads than ServerProcess's 4: a dozen posts arrive at each at once.
    std::vector<std::string> args() const {
        return {"--data-dir", data.string(), "--threads", "32"};
    }
};

TEST_F(SharedStore, TwoProcessesRacingToRegisterAgree) {
    testing::ServerProcess a(args()), b(args());
    constexpr int kScenes = 4, kPostsPerServer = 3;
    std::mutex mu;
    std::map<std::string, std::multiset<int>> statuses;  // id → the statuses its posts got
    std::vector<std::string> errors;
    std::vector<std::thread> threads;
    for (int s = 0; s < kScenes; ++s) {
        for (int k = 0; k < 2 * kPostsPerServer; ++k) {
            threads.emplace_back([&, s, k] {
                auto res =
                    (k % 2 ? a : b).client()->Post("/v1/scenes", scene(s), "application/json");
                std::lock_guard<std::mutex> lock(mu);
                if (!res || (res->status != 200 && res->status != 201)) {
                    errors.push_back(res ? std::to_string(res->status) + " " + res->body
                                         : "no answer");
                    return;
                }
                statuses[Json::parse(res->body).at("id")].insert(res->status);
            });
        }
    }
    for (auto& t : threads)
        t.join();
    ASSERT_TRUE(errors.empty()) << errors.front();
    ASSERT_EQ(statuses.size(), static_cast<std::size_t>(kScenes));
    for (const auto& [id, got] : statuses)
        EXPECT_EQ(got.count(201), 1u) << id << ": exactly one writer published it";

    // The store holds whole copies and no leftovers.
    EXPECT_TRUE(fs::is_empty(data / "tmp"));
    for (const auto& [id, got] : statuses) {
        EXPECT_TRUE(fs::exists(data / "scenes" / id / "meta.json")) << id;
        EXPECT_TRUE(fs::exists(data / "scenes" / id / "body")) << id;
    }
    // A scene sent to a only is answered by b, on demand from the store.
    auto only_a = a.client()->Post("/v1/scenes", scene(99), "application/json");
    ASSERT_TRUE(only_a);
    ASSERT_EQ(only_a->status, 201);
    statuses[Json::parse(only_a->body).at("id")];

    testing::ServerProcess c(args());  // started after it all
    auto listed = c.client()->Get("/v1/scenes");
    ASSERT_TRUE(listed);
    EXPECT_EQ(Json::parse(listed->body).at("scenes").size(), statuses.size());
    for (const auto& [id, got] : statuses) {
        std::string first;
        for (testing::ServerProcess* s : {&a, &b, &c}) {
            auto res = s->client()->Post(("/v1/scenes/" + id + "/intersect").c_str(), kRays,
                                         "application/json");
            ASSERT_TRUE(res) << id;
            ASSERT_EQ(res->status, 200) << id << ": " << res->body;
            if (first.empty()) {
                first = res->body;
                EXPECT_TRUE(Json::parse(first).at("hits").at(0).is_object()) << first;
            }
            EXPECT_EQ(res->body, first) << id << " answered differently on port " << s->port();
        }
    }
    // Deleted through one replica: another that has not loaded it answers 404, not 500.
    const std::string last = std::prev(statuses.end())->first;
    ASSERT_EQ(b.client()->Delete(("/v1/scenes/" + last).c_str())->status, 200);
    testing::ServerProcess d(args());
    EXPECT_EQ(d.client()->Get(("/v1/scenes/" + last).c_str())->status, 404);
}

}  // namespace
}  // namespace raycastd
