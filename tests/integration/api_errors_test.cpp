// The error table of docs/api.md against the real binary: status, code and path for each bad
// input, and the server still answering afterwards.

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/server_process.h"

namespace raycastd {
namespace {

using Json = nlohmann::json;

const char* kScene = R"({"objects":[{"type":"sphere","center":[0,0,10],"radius":2}]})";

class ApiErrors : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        server_ = new testing::ServerProcess({"--max-body-mb", "1", "--max-rays", "1000"});
    }
    static void TearDownTestSuite() {
        delete server_;
        server_ = nullptr;
    }
    /// POSTs and checks status, error code and (when given) path.
    static void expect_error(const std::string& target, const std::string& body, int status,
                             const std::string& code, const std::string& path = "") {
        auto res = server_->client()->Post(target, body, "application/json");
        ASSERT_TRUE(res) << "no response for " << body.substr(0, 200);
        EXPECT_EQ(res->status, status) << res->body;
        EXPECT_EQ(res->get_header_value("Content-Type"), "application/json");
        Json j = Json::parse(res->body);
        EXPECT_EQ(j.at("error").at("code"), code) << res->body;
        EXPECT_FALSE(j.at("error").at("message").get<std::string>().empty());
        if (!path.empty()) {
            EXPECT_EQ(j.at("error").at("path"), path) << res->body;
        }
        auto health = server_->client()->Get("/v1/health");
        ASSERT_TRUE(health) << "server stopped answering after " << body.substr(0, 200);
        EXPECT_EQ(health->body, R"({"status":"ok"})");
    }
    static std::string intersect(const std::string& scene, const std::string& rays) {
        return std::string(R"({"scene":)") + scene + R"(,"rays":)" + rays + "}";
    }
    static testing::ServerProcess* server_;
};
testing::ServerProcess* ApiErrors::server_ = nullptr;

TEST_F(ApiErrors, BadJson) {
    expect_error("/v1/intersect", "{\"scene\": ", 400, "bad_json");
    expect_error("/v1/intersect", "[1, 2,]", 400, "bad_json");
    expect_error("/v1/intersect", "", 400, "bad_json");
    // JSON cannot carry NaN or infinity.
    expect_error("/v1/intersect",
                 intersect(kScene, R"([{"origin":[0,0,0],"direction":[NaN,0,1]}])"), 400,
                 "bad_json");
    expect_error("/v1/intersect",
                 intersect(kScene, R"([{"origin":[0,0,0],"direction":[1e999,0,1]}])"), 400,
                 "bad_json");
}

TEST_F(ApiErrors, InvalidRay) {
    expect_error("/v1/intersect", intersect(kScene, R"([{"origin":[0,0,0],"direction":[0,0,1]},
                                                      {"origin":[0,0,0],"direction":[0,0,0]}])"),
                 400, "invalid_ray", "/rays/1/direction");
    expect_error("/v1/intersect",
                 intersect(kScene, R"([{"origin":[0,0,0],"direction":[0,0,1],"tmin":5,"tmax":1}])"),
                 400, "invalid_ray", "/rays/0/tmin");
    expect_error("/v1/intersect", intersect(kScene, R"([{"origin":[0,0],"direction":[0,0,1]}])"),
                 400, "invalid_ray", "/rays/0/origin");
}

TEST_F(ApiErrors, InvalidScene) {
    expect_error("/v1/intersect",
                 intersect(R"({"objects":[{"type":"sphere","center":[0,0,10],"radius":-1}]})",
                           R"([{"origin":[0,0,0],"direction":[0,0,1]}])"),
                 400, "invalid_scene", "/scene/objects/0/radius");
    expect_error("/v1/intersect",
                 intersect(R"({"objects":[{"type":"cylinder"}]})",
                           R"([{"origin":[0,0,0],"direction":[0,0,1]}])"),
                 400, "invalid_scene", "/scene/objects/0/type");
    expect_error("/v1/intersect", R"({"rays":[]})", 400, "invalid_request", "/scene");
    // A scene reaching past the largest double (docs/api.md).
    expect_error("/v1/intersect",
                 intersect(R"({"objects":[{"type":"sphere","center":[1e308,0,0],"radius":1e308}]})",
                           R"([{"origin":[0,0,0],"direction":[0,0,1]}])"),
                 400, "invalid_scene", "/scene/objects/0");
}

TEST_F(ApiErrors, InvalidRequest) {
    expect_error("/v1/intersect", R"({"scene":{"objects":[]},"rays":[],"mode":"nearest"})", 400,
                 "invalid_request", "/mode");
    expect_error("/v1/explain?format=pdf", R"({})", 400, "unsupported_format");
    expect_error("/v1/explain", R"({"scene":{"objects":[]}})", 400, "invalid_request", "/ray");
}

TEST_F(ApiErrors, TooLarge) {
    std::string rays = "[";
    for (int i = 0; i < 1001; ++i)
        rays += std::string(i ? "," : "") + R"({"origin":[0,0,0],"direction":[0,0,1]})";
    rays += "]";
    expect_error("/v1/intersect", intersect(kScene, rays), 413, "too_large", "/rays");
    expect_error("/v1/intersect", std::string(2u << 20, ' '), 413, "too_large");
}

// One reader for every JSON body: the same bad body gets the same code and message (with its
// byte offset) from every endpoint that takes JSON, whichever path reads it there.
TEST_F(ApiErrors, TheSameBadJsonGetsTheSameErrorEverywhere) {
    auto added = server_->client()->Post("/v1/scenes", kScene, "application/json");
    ASSERT_TRUE(added);
    ASSERT_LT(added->status, 300) << added->body;
    const std::string id = Json::parse(added->body).at("id");
    const std::vector<std::string> endpoints = {
        "/v1/intersect", "/v1/scenes/" + id + "/intersect", "/v1/scenes",
        "/v1/explain",   "/v1/scenes/" + id + "/trace",     "/v1/scenes/" + id + "/render"};
    for (const std::string& body :
         {std::string(R"({"rays": [{"origin": [0, 0, 0], "direction": [0, 0,)"),
          std::string(R"({"rays": [{"origin": [0, 0, 0], "direction": [1e999, 0, 1]}]})"),
          std::string(R"({"rays": [{"origin": [0, 0, 0], "direction": [NaN, 0, 1]}]})"),
          std::string("")}) {
        std::string first;
        for (const std::string& target : endpoints) {
            if (body.empty() && target.find("/render") != std::string::npos)
                continue;  // an empty render body asks for every default
            auto res = server_->client()->Post(target, body, "application/json");
            ASSERT_TRUE(res) << target;
            EXPECT_EQ(res->status, 400) << target << ": " << res->body;
            const Json err = Json::parse(res->body).at("error");
            EXPECT_EQ(err.at("code"), "bad_json") << target;
            EXPECT_FALSE(err.contains("path")) << target;
            const std::string message = err.at("message");
            EXPECT_EQ(message.rfind("body is not valid JSON: byte ", 0), 0u) << message;
            if (first.empty())
                first = message;
            EXPECT_EQ(message, first) << target << " for body " << body;
        }
    }
}

// A known path asked with a method it does not have: 405 with the methods it has in Allow.
TEST_F(ApiErrors, MethodNotAllowedListsTheAllowedMethods) {
    const auto expect_405 = [](const httplib::Result& res, const std::string& allow) {
        ASSERT_TRUE(res);
        EXPECT_EQ(res->status, 405) << res->body;
        EXPECT_EQ(res->get_header_value("Allow"), allow);
        EXPECT_EQ(res->get_header_value("Content-Type"), "application/json");
        const Json err = Json::parse(res->body).at("error");
        EXPECT_EQ(err.at("code"), "method_not_allowed") << res->body;
        EXPECT_FALSE(err.at("message").get<std::string>().empty());
    };
    auto c = server_->client();
    expect_405(c->Get("/v1/intersect"), "POST");
    expect_405(c->Delete("/v1/health"), "GET, HEAD");
    expect_405(c->Put("/v1/scenes", kScene, "application/json"), "GET, HEAD, POST");
    expect_405(c->Patch("/v1/scenes/sc_0000", "{}", "application/json"), "GET, HEAD, DELETE");
    expect_405(c->Get("/v1/scenes/sc_0000/intersect"), "POST");
    expect_405(c->Post("/v1/info", "{}", "application/json"), "GET, HEAD");
    expect_405(c->Delete("/v1/jobs/jb_0000/image"), "GET, HEAD");
    // A path of no route stays 404 not_found, whatever the method.
    auto res = c->Delete("/v1/nothing-here");
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 404);
    EXPECT_EQ(Json::parse(res->body).at("error").at("code"), "not_found");
    // And the methods a path has still work.
    res = c->Get("/v1/health");
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 200);
}

TEST_F(ApiErrors, UrlOverTheLimitIs414TooLarge) {
    auto res = server_->client()->Get("/v1/" + std::string(9000, 'a'));
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 414);
    EXPECT_EQ(Json::parse(res->body).at("error").at("code"), "too_large") << res->body;
}

TEST_F(ApiErrors, UnknownEndpoint) {
    auto res = server_->client()->Get("/v1/nothing-here");
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 404);
    EXPECT_EQ(Json::parse(res->body).at("error").at("code"), "not_found");
}

TEST_F(ApiErrors, EveryResponseHasARequestId) {
    auto res = server_->client()->Get("/v1/health");
    ASSERT_TRUE(res);
    EXPECT_EQ(res->get_header_value("X-Request-Id").rfind("rq_", 0), 0u);
}

TEST_F(ApiErrors, InfoAndOpenApi) {
    auto res = server_->client()->Get("/v1/info");
    ASSERT_TRUE(res);
    Json info = Json::parse(res->body);
    EXPECT_EQ(info.at("embree_version"), "3.13.5");
    EXPECT_EQ(info.at("limits").at("max_rays"), 1000);
    res = server_->client()->Get("/v1/openapi.json");
    ASSERT_TRUE(res);
    Json api = Json::parse(res->body);
    EXPECT_EQ(api.at("openapi"), "3.0.3");
    EXPECT_TRUE(api.at("paths").contains("/v1/intersect"));
}

// cpp-httplib serves a keep-alive connection on one worker until the client goes quiet (30 s):
// with the old default of 4 workers a fifth keep-alive client waited that long. With the
// default worker count (--threads 0 = default), a dozen keep-alive clients, all holding their
// connections open, are each answered at once.
TEST(ServerThreads, DozenKeepAliveClientsAreAllServed) {
    testing::ServerProcess server({"--threads", "0"});
    std::vector<std::unique_ptr<httplib::Client>> clients;
    for (int i = 0; i < 12; ++i) {
        clients.push_back(server.client());
        clients.back()->set_keep_alive(true);
        clients.back()->set_read_timeout(3, 0);
        auto res = clients.back()->Get("/v1/health");
        ASSERT_TRUE(res) << "client " << i << " was not served";
        EXPECT_EQ(res->status, 200);
    }
    for (auto& c : clients) {  // and again, every connection still open
        auto res = c->Get("/v1/health");
        ASSERT_TRUE(res);
        EXPECT_EQ(res->status, 200);
    }
}

}  // namespace
}  // namespace raycastd
