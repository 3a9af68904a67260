// The points request over HTTP: JSON and binary forms agree, each query on a registered scene,
// the stateless form, the errors (bad points name their index), and `topology` in the scene
// response, also after a restart from the data directory.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "engine/testing/point_meshes.h"
#include "tests/support/encode.h"
#include "tests/support/server_process.h"

namespace raycastd {
namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

/// A scene document: a unit sphere at (5, 0, 0), a closed cube [0, 1]³ and an open cube
/// [−3, −2]³ (its top face removed).
Json scene_doc() {
    const auto cube = engine::testing::cube_object(0, 1);
    const auto open = engine::testing::open_cube_object(-3, -2);
    return {{"objects",
             {{{"type", "sphere"}, {"center", {5, 0, 0}}, {"radius", 1}},
              {{"type", "mesh"},
               {"format", "obj"},
               {"name", "cube"},
               {"data_base64", testing::base64(testing::to_obj(*cube.mesh))}},
              {{"type", "mesh"},
               {"format", "obj"},
               {"name", "open"},
               {"data_base64", testing::base64(testing::to_obj(*open.mesh))}}}}};
}

const std::vector<std::array<double, 3>> kPoints = {
    {0.5, 0.5, 0.5},     // inside the cube
    {0.5, 0.5, 3},       // above it
    {1, 1, 1},           // on its corner
    {5, 0, 0.5},         // inside the sphere
    {-2.5, -2.5, -2.5},  // inside the open cube (winding 5/6)
    {-2.5, -2.5, -1.5},  // above the open cube's hole
};

struct Points : ::testing::Test {
    static void SetUpTestSuite() {
        server_ = new testing::ServerProcess();
        auto res = server_->client()->Post("/v1/scenes", scene_doc().dump(), "application/json");
        ASSERT_TRUE(res);
        ASSERT_EQ(res->status, 201) << res->body;
        info_ = Json::parse(res->body);
        id_ = info_.at("id");
    }
    static void TearDownTestSuite() {
        delete server_;
        server_ = nullptr;
    }
    static Json post_json(const std::string& path, const Json& body, int status = 200) {
        auto res = server_->client()->Post(path.c_str(), body.dump(), "application/json");
        EXPECT_TRUE(res);
        if (!res)
            return Json();
        EXPECT_EQ(res->status, status) << res->body;
        return Json::parse(res->body);
    }
    static Json ask(const std::string& query, double max_distance = 1e30) {
        return post_json("/v1/scenes/" + id_ + "/points",
                         {{"points", kPoints}, {"query", query}, {"max_distance", max_distance}});
    }
    /// The binary answer of `query` for kPoints as float64 records.
    static std::string ask_binary(const std::string& query, const std::string& dtype,
                                  int status = 200) {
        return ask_binary(query, dtype, kPoints, status);
    }
    /// The binary answer of `query` for `points`.
    static std::string ask_binary(const std::string& query, const std::string& dtype,
                                  const std::vector<std::array<double, 3>>& points,
                                  int status = 200) {
        std::string body;
        for (const auto& p : points) {
            for (double c : p) {
                if (dtype == "float32") {
                    const float f = static_cast<float>(c);
                    body.append(reinterpret_cast<const char*>(&f), sizeof f);
                } else {
                    body.append(reinterpret_cast<const char*>(&c), sizeof c);
                }
            }
        }
        const std::string path = "/v1/scenes/" + id_ + "/points?query=" + query + "&dtype=" + dtype;
        auto res = server_->client()->Post(path.c_str(), body, "application/octet-stream");
        EXPECT_TRUE(res);
        if (!res)
            return {};
        EXPECT_EQ(res->status, status) << res->body;
        return res->body;
    }
    static testing::ServerProcess* server_;
    static std::string id_;
    static Json info_;
};
testing::ServerProcess* Points::server_ = nullptr;
std::string Points::id_;
Json Points::info_;

TEST_F(Points, TopologyInTheSceneResponse) {
    const Json& topo = info_.at("topology");
    ASSERT_EQ(topo.size(), 2u);  // the two meshes; the sphere has none
    EXPECT_EQ(topo[0].at("object"), 1);
    EXPECT_EQ(topo[0].at("name"), "cube");
    EXPECT_EQ(topo[0].at("vertices"), 8);
    EXPECT_EQ(topo[0].at("triangles"), 12);
    EXPECT_EQ(topo[0].at("closed"), true);
    EXPECT_EQ(topo[0].at("euler_characteristic"), 2);
    EXPECT_EQ(topo[0].at("sign"), "parity");
    EXPECT_EQ(topo[1].at("boundary_edges"), 4);
    EXPECT_EQ(topo[1].at("boundary_loops"), 1);
    EXPECT_EQ(topo[1].at("closed"), false);
    EXPECT_EQ(topo[1].at("sign"), "winding");
    auto res = server_->client()->Get(("/v1/scenes/" + id_).c_str());
    ASSERT_TRUE(res);
    EXPECT_EQ(Json::parse(res->body).at("topology"), topo);
}

TEST_F(Points, ClosestJson) {
    const Json r = ask("closest");
    EXPECT_EQ(r.at("query"), "closest");
    const Json& res = r.at("results");
    ASSERT_EQ(res.size(), kPoints.size());
    EXPECT_EQ(res[1].at("found"), true);
    EXPECT_EQ(res[1].at("point"), Json({0.5, 0.5, 1}));
    EXPECT_EQ(res[1].at("distance"), 2.0);
    EXPECT_EQ(res[1].at("object"), 1);
    EXPECT_EQ(res[1].at("name"), "cube");
    EXPECT_EQ(res[1].at("normal"), Json({0, 0, 1}));
    EXPECT_EQ(res[2].at("distance"), 0.0);
    EXPECT_EQ(res[2].at("point"), Json({1, 1, 1}));
    EXPECT_EQ(res[3].at("object"), 0);
    EXPECT_EQ(res[3].at("name"), "sphere 1");
    EXPECT_EQ(res[3].at("distance"), 0.5);
    // max_distance: the point above the cube is 2 away.
    EXPECT_EQ(ask("closest", 1.5).at("results")[1], Json({{"found", false}}));
}

TEST_F(Points, SignedDistanceAndOccupancyJson) {
    const Json sd = ask("signed_distance").at("results");
    EXPECT_EQ(sd[0].at("distance"), -0.5);
    EXPECT_EQ(sd[1].at("distance"), 2.0);
    EXPECT_EQ(sd[2].at("distance"), 0.0);
    EXPECT_EQ(sd[3].at("distance"), -0.5);
    EXPECT_LT(sd[4].at("distance").get<double>(), 0.0);
    EXPECT_GT(sd[5].at("distance").get<double>(), 0.0);
    const Json occ = ask("occupancy").at("results");
    const bool inside[] = {true, false, true, true, true, false};
    for (std::size_t i = 0; i < kPoints.size(); ++i)
        EXPECT_EQ(occ[i].at("inside"), inside[i]) << i;
    EXPECT_EQ(occ[0].at("winding"), 1.0);
    EXPECT_NEAR(occ[4].at("winding").get<double>(), 5.0 / 6.0, 1e-9);
    const Json d = ask("distance").at("results");
    EXPECT_EQ(d[0].at("distance"), 0.5);
}

TEST_F(Points, BinaryAgreesWithJson) {
    const Json closest = ask("closest").at("results");
    const std::string c64 = ask_binary("closest", "float64");
    ASSERT_EQ(c64.size(), kPoints.size() * 56);
    for (std::size_t i = 0; i < kPoints.size(); ++i) {
        double f[4];
        std::uint32_t ids[2];
        std::memcpy(f, c64.data() + 56 * i, 32);
        std::memcpy(ids, c64.data() + 56 * i + 32, 8);
        EXPECT_EQ(f[0], closest[i].at("point")[0].get<double>());
        EXPECT_EQ(f[3], closest[i].at("distance").get<double>());
        EXPECT_EQ(ids[0], closest[i].at("object").get<std::uint32_t>());
        EXPECT_EQ(ids[1], closest[i].at("primitive").get<std::uint32_t>());
    }
    EXPECT_EQ(ask_binary("closest", "float32").size(), kPoints.size() * 32);
    const Json sd = ask("signed_distance").at("results");
    const std::string s64 = ask_binary("signed_distance", "float64");
    ASSERT_EQ(s64.size(), kPoints.size() * 8);
    const Json occ = ask("occupancy").at("results");
    const std::string o32 = ask_binary("occupancy", "float32");
    ASSERT_EQ(o32.size(), kPoints.size() * 4);
    for (std::size_t i = 0; i < kPoints.size(); ++i) {
        double d;
        std::memcpy(&d, s64.data() + 8 * i, 8);
        EXPECT_EQ(d, sd[i].at("distance").get<double>());
        float w;
        std::memcpy(&w, o32.data() + 4 * i, 4);
        EXPECT_EQ(w, static_cast<float>(occ[i].at("winding").get<double>()));
        EXPECT_EQ(w >= 0.5f, occ[i].at("inside").get<bool>());
    }
}

// A batch of 4,096 points or more is taken in its spatial order, with the point tree built before
// its loop and the points prefetched (engine/points/batch.h, point_queries.cpp); a smaller one in
// the order given. Over HTTP the answers are the same bit for bit: a lattice of 17³ points over
// the three objects (many of them equidistant from two faces, edges or corners: exact ties, which
// the lower object and primitive must win in either order), asked in one batch and in batches of
// 1,000, closest and signed distance, in float64 records.
TEST_F(Points, ALargeBatchAnswersAsSmallOnes) {
    std::vector<std::array<double, 3>> lattice;
    for (int i = 0; i <= 16; ++i) {
        for (int j = 0; j <= 16; ++j) {
            for (int k = 0; k <= 16; ++k)
                lattice.push_back({-3.5 + 0.625 * i, -3.5 + 0.3125 * j, -3.5 + 0.3125 * k});
        }
    }
    ASSERT_GE(lattice.size(), 4096u);  // engine::kSpatialOrderMin
    for (const std::string query : {"closest", "signed_distance"}) {
        const std::string whole = ask_binary(query, "float64", lattice);
        std::string parts;
        for (std::size_t at = 0; at < lattice.size(); at += 1000) {
            const auto end = lattice.begin() + std::ptrdiff_t(std::min(at + 1000, lattice.size()));
            parts += ask_binary(query, "float64", {lattice.begin() + std::ptrdiff_t(at), end});
        }
        ASSERT_EQ(whole.size(), parts.size()) << query;
        ASSERT_EQ(whole.size() % lattice.size(), 0u) << query;
        const std::size_t record = whole.size() / lattice.size();
        std::size_t differ = 0;
        for (std::size_t i = 0; i < lattice.size(); ++i)
            differ += whole.compare(i * record, record, parts, i * record, record) != 0;
        EXPECT_EQ(differ, 0u) << query;
    }
}

TEST_F(Points, BadPointsNameTheirIndex) {
    const Json e =
        post_json("/v1/scenes/" + id_ + "/points", {{"points", {{0, 0, 0}, {1, 2}}}}, 400);
    EXPECT_EQ(e.at("error").at("code"), "invalid_request");
    EXPECT_EQ(e.at("error").at("path"), "/points/1");
    // Three float32 points, the third (3.4e38, NaN, 0).
    auto res = server_->client()->Post(("/v1/scenes/" + id_ + "/points?dtype=float32").c_str(),
                                       std::string(24, '\0') + std::string(4, '\x7f') +
                                           std::string(4, '\xff') + std::string(4, '\0'),
                                       "application/octet-stream");
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 400);
    const Json b = Json::parse(res->body);
    EXPECT_EQ(b.at("error").at("code"), "invalid_request");
    EXPECT_EQ(b.at("error").at("path"), "/points/2");
    // JSON cannot carry NaN: a body with one is bad_json.
    res = server_->client()->Post(("/v1/scenes/" + id_ + "/points").c_str(),
                                  R"({"points": [[0, 0, NaN]]})", "application/json");
    ASSERT_TRUE(res);
    EXPECT_EQ(Json::parse(res->body).at("error").at("code"), "bad_json");
    EXPECT_EQ(post_json("/v1/scenes/" + id_ + "/points",
                        {{"points", {{0, 0, 0}}}, {"query", "nearest"}}, 400)
                  .at("error")
                  .at("path"),
              "/query");
    EXPECT_EQ(post_json("/v1/scenes/sc_nope/points", {{"points", {{0, 0, 0}}}}, 404)
                  .at("error")
                  .at("code"),
              "scene_not_found");
}

TEST_F(Points, Stateless) {
    Json body = {{"scene", scene_doc()}, {"points", kPoints}, {"query", "occupancy"}};
    const Json r = post_json("/v1/points", body);
    EXPECT_EQ(r.at("results"), ask("occupancy").at("results"));
    body.erase("scene");
    EXPECT_EQ(post_json("/v1/points", body, 400).at("error").at("path"), "/scene");
}

TEST(PointsLimits, MaxPoints) {
    testing::ServerProcess server({"--max-points", "2"});
    auto c = server.client();
    Json body = {{"scene", scene_doc()}, {"points", kPoints}};
    auto res = c->Post("/v1/points", body.dump(), "application/json");
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 413);
    auto info = c->Get("/v1/info");
    ASSERT_TRUE(info);
    EXPECT_EQ(Json::parse(info->body).at("limits").at("max_points"), 2);
}

TEST(PointsTopology, PersistsAcrossARestart) {
    const fs::path data =
        fs::temp_directory_path() / ("raycastd_points_" + std::to_string(::getpid()));
    fs::remove_all(data);
    Json first;
    std::string id;
    {
        testing::ServerProcess server({"--data-dir", data.string()});
        auto res = server.client()->Post("/v1/scenes", scene_doc().dump(), "application/json");
        ASSERT_TRUE(res);
        first = Json::parse(res->body).at("topology");
        id = Json::parse(res->body).at("id");
        server.stop(SIGKILL);
    }
    testing::ServerProcess again({"--data-dir", data.string()});
    auto res = again.client()->Get(("/v1/scenes/" + id).c_str());
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200);
    EXPECT_EQ(Json::parse(res->body).at("topology"), first);
    EXPECT_EQ(first.size(), 2u);
    fs::remove_all(data);
}

}  // namespace
}  // namespace raycastd
