// The tutorial's Question 1 against the real raycastd binary: the grading-script path.

#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/server_process.h"

namespace raycastd {
namespace {

using Json = nlohmann::json;

std::string read_file(const std::string& path) {
    std::ifstream f(path);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

class Tutorial : public ::testing::Test {
  protected:
    static void SetUpTestSuite() { server_ = new testing::ServerProcess(); }
    static void TearDownTestSuite() {
        delete server_;
        server_ = nullptr;
    }
    static testing::ServerProcess* server_;
};
testing::ServerProcess* Tutorial::server_ = nullptr;

TEST_F(Tutorial, Question1NamesSphere3) {
    auto c = server_->client();
    auto res = c->Post("/v1/intersect",
                       read_file(RAYCASTD_SOURCE_DIR "/clients/examples/tutorial-q1.json"),
                       "application/json");
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << res->body;
    // The exact text a grading script greps for.
    EXPECT_NE(res->body.find("\"t\":7.267949192431123"), std::string::npos) << res->body;
    Json j = Json::parse(res->body);
    const Json& hit = j.at("hits").at(0);
    EXPECT_EQ(hit.at("name"), "sphere 3");
    EXPECT_EQ(hit.at("object"), 2);
    EXPECT_EQ(hit.at("t").get<double>(), 7.267949192431123);
    EXPECT_EQ(hit.at("point"), Json::parse("[0, 0, 7.267949192431123]"));
    // (p − c)/r = (0, −1, −√3)/2, with p's last-bit rounding in z.
    EXPECT_EQ(hit.at("normal").at(1).get<double>(), -0.5);
    EXPECT_NEAR(hit.at("normal").at(2).get<double>(), -std::sqrt(3.0) / 2, 1e-15);
    EXPECT_EQ(hit.at("front_face"), true);
    EXPECT_EQ(j.at("precision"), "exact");
}

TEST_F(Tutorial, ModesAllAndCount) {
    Json body = Json::parse(read_file(RAYCASTD_SOURCE_DIR "/clients/examples/tutorial-q1.json"));
    body["mode"] = "all";
    body["fields"] = {"t", "name"};
    auto c = server_->client();
    auto res = c->Post("/v1/intersect", body.dump(), "application/json");
    ASSERT_TRUE(res);
    Json j = Json::parse(res->body);
    const Json& r = j.at("hits").at(0);
    EXPECT_EQ(r.at("count"), 4);
    EXPECT_EQ(r.at("hits").at(1), Json::parse(R"({"hit": true, "t": 8, "name": "sphere 1"})"));
    body["mode"] = "count";
    res = c->Post("/v1/intersect", body.dump(), "application/json");
    EXPECT_EQ(Json::parse(res->body).at("hits").at(0), Json::parse(R"({"count": 4})"));
    body["mode"] = "any";
    res = c->Post("/v1/intersect", body.dump(), "application/json");
    EXPECT_EQ(Json::parse(res->body).at("hits").at(0), Json::parse(R"({"hit": true})"));
}

TEST_F(Tutorial, ExplainGivesTheWorkedSolution) {
    auto c = server_->client();
    const std::string body =
        read_file(RAYCASTD_SOURCE_DIR "/clients/examples/tutorial-q1-explain.json");
    auto res = c->Post("/v1/explain", body, "application/json");
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << res->body;
    Json j = Json::parse(res->body);
    const Json& s1 = j.at("objects").at(0);
    EXPECT_EQ(s1.at("name"), "sphere 1");
    EXPECT_EQ(s1.at("coefficients"), Json::parse(R"({"a": 1, "b": -20, "c": 96})"));
    EXPECT_EQ(s1.at("discriminant"), 16);
    EXPECT_EQ(s1.at("roots"), Json::parse("[8, 12]"));
    EXPECT_EQ(s1.at("steps").at(2), "(0-0)^2+(0-0)^2+(t-10)^2 = 2^2");
    const Json& s2 = j.at("objects").at(1);
    EXPECT_EQ(s2.at("hit"), false);
    EXPECT_EQ(s2.at("roots"), Json::array());
    EXPECT_EQ(s2.at("reason"), "no real roots: the ray misses");
    EXPECT_EQ(j.at("first_hit").at("name"), "sphere 3");
    EXPECT_EQ(j.at("first_hit").at("t").get<double>(), 7.267949192431123);

    res = c->Post("/v1/explain?format=markdown", body, "application/json");
    ASSERT_EQ(res->status, 200);
    EXPECT_EQ(res->get_header_value("Content-Type"), "text/markdown; charset=utf-8");
    EXPECT_NE(res->body.find("first hits **sphere 3**"), std::string::npos) << res->body;
    EXPECT_NE(res->body.find("no real roots"), std::string::npos);
}

TEST_F(Tutorial, ExplainMissIsNull) {
    Json body =
        Json::parse(read_file(RAYCASTD_SOURCE_DIR "/clients/examples/tutorial-q1-explain.json"));
    body["ray"]["direction"] = {0, 0, -1};
    auto res = server_->client()->Post("/v1/explain", body.dump(), "application/json");
    ASSERT_TRUE(res);
    EXPECT_TRUE(Json::parse(res->body).at("first_hit").is_null());
}

// A sphere of radius 1e-300 five units down the ray is below double's resolution there, and
// every precision takes it as missed: the worked solution says so, with no discriminant written
// (it had read "discriminant B^2-4AC = 0" above "no real roots"), and /v1/intersect agrees.
TEST_F(Tutorial, ExplainSaysWhyASphereBelowDoublesResolutionIsMissed) {
    const Json scene = {
        {"objects", {{{"type", "sphere"}, {"center", {0, 0, 5}}, {"radius", 1e-300}}}}};
    const Json ray = {{"origin", {0, 0, 0}}, {"direction", {0, 0, 1}}};
    auto res = server_->client()->Post("/v1/explain", Json{{"scene", scene}, {"ray", ray}}.dump(),
                                       "application/json");
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << res->body;
    const Json work = Json::parse(res->body).at("objects").at(0);
    EXPECT_FALSE(work.at("hit").get<bool>());
    EXPECT_NE(work.at("reason").get<std::string>().find("below 2^-900 of its distance"),
              std::string::npos)
        << res->body;
    EXPECT_TRUE(work.at("discriminant").is_null()) << res->body;
    EXPECT_TRUE(work.at("out_of_range").get<bool>()) << res->body;
    res = server_->client()->Post("/v1/intersect", Json{{"scene", scene}, {"rays", {ray}}}.dump(),
                                  "application/json");
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << res->body;
    EXPECT_FALSE(Json::parse(res->body).at("hits").at(0).at("hit").get<bool>()) << res->body;
}

}  // namespace
}  // namespace raycastd
