// GET / and GET /web/<path> (the preview page, API.md "GET /") against the real binary: the page
// is HTML, its modules have a JavaScript MIME type, a missing file is the API's JSON 404, and
// paths that climb out of the web root (.., encoded or not, or through a symlink) are refused.

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "tests/support/server_process.h"

namespace raycastd {
namespace {

using Json = nlohmann::json;
namespace fs = std::filesystem;

class Web : public ::testing::Test {
  protected:
    static void SetUpTestSuite() { server_ = new testing::ServerProcess(); }
    static void TearDownTestSuite() {
        delete server_;
        server_ = nullptr;
    }
    /// The JSON error code of a GET that must fail with `status`.
    static std::string error_code(httplib::Client& client, const std::string& target, int status) {
        auto res = client.Get(target.c_str());
        EXPECT_TRUE(res) << target;
        if (!res)
            return "";
        EXPECT_EQ(res->status, status) << target << ": " << res->body;
        EXPECT_EQ(res->get_header_value("Content-Type"), "application/json") << target;
        return Json::parse(res->body).at("error").at("code").get<std::string>();
    }
    static testing::ServerProcess* server_;
};
testing::ServerProcess* Web::server_ = nullptr;

TEST_F(Web, RootServesThePage) {
    auto res = server_->client()->Get("/");
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 200);
    EXPECT_EQ(res->get_header_value("Content-Type"), "text/html; charset=utf-8");
    EXPECT_EQ(res->body.rfind("<!doctype html>", 0), 0u) << res->body.substr(0, 80);
    EXPECT_NE(res->body.find("web/js/app.js"), std::string::npos);
    EXPECT_EQ(res->get_header_value("X-Content-Type-Options"), "nosniff");
    EXPECT_NE(res->get_header_value("Content-Security-Policy").find("default-src 'self'"),
              std::string::npos);
    EXPECT_EQ(res->get_header_value("Cache-Control"), "no-cache");
    EXPECT_FALSE(res->get_header_value("ETag").empty());
}

TEST_F(Web, AssetsHaveTheirTypesAndRevalidate) {
    auto client = server_->client();
    auto js = client->Get("/web/js/app.js");
    ASSERT_TRUE(js);
    EXPECT_EQ(js->status, 200);
    EXPECT_EQ(js->get_header_value("Content-Type"), "text/javascript; charset=utf-8");
    auto css = client->Get("/web/style.css");
    ASSERT_TRUE(css);
    EXPECT_EQ(css->get_header_value("Content-Type"), "text/css; charset=utf-8");

    const std::string etag = js->get_header_value("ETag");
    auto again = client->Get("/web/js/app.js", {{"If-None-Match", etag}});
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 304);
    EXPECT_TRUE(again->body.empty());
}

TEST_F(Web, AMissingAssetIsTheApisJson404) {
    auto client = server_->client();
    EXPECT_EQ(error_code(*client, "/web/missing.js", 404), "not_found");
    EXPECT_EQ(error_code(*client, "/web/js", 404), "not_found");  // a directory
    EXPECT_EQ(error_code(*client, "/web/README.md.bak", 404), "not_found");
    // The API's own 404 is unchanged by the new routes.
    EXPECT_EQ(error_code(*client, "/v1/no-such-endpoint", 404), "not_found");
}

TEST_F(Web, EscapesAreRefused) {
    auto client = server_->client();
    // httplib's client sends the target as written, as curl --path-as-is does; the server
    // percent-decodes before routing, so the encoded forms arrive as ".." too.
    for (const char* target :
         {"/web/../CMakeLists.txt", "/web/js/../../CMakeLists.txt", "/web/%2e%2e/CMakeLists.txt",
          "/web/..%2fCMakeLists.txt", "/web/%2E%2E%2F%2E%2E%2Fserver%2Fapp.cpp", "/web//etc/passwd",
          "/web/.git/config"}) {
        EXPECT_EQ(error_code(*client, target, 400), "invalid_request") << target;
    }
    auto health = client->Get("/v1/health");
    ASSERT_TRUE(health);
    EXPECT_EQ(health->status, 200);
}

TEST(WebRoot, TheEnvironmentChoosesTheRootAndSymlinksOutOfItAreRefused) {
    const fs::path base =
        fs::temp_directory_path() / ("raycastd_webroot_" + std::to_string(getpid()));
    fs::remove_all(base);
    fs::create_directories(base / "root");
    std::ofstream(base / "root" / "index.html") << "<!doctype html><title>other page</title>";
    std::ofstream(base / "secret.txt") << "secret\n";
    fs::create_symlink(base / "secret.txt", base / "root" / "secret.txt");
    ::setenv("RAYCASTD_WEB_ROOT", (base / "root").c_str(), 1);
    testing::ServerProcess server;
    ::unsetenv("RAYCASTD_WEB_ROOT");
    auto client = server.client();

    auto page = client->Get("/");
    ASSERT_TRUE(page);
    EXPECT_EQ(page->body, "<!doctype html><title>other page</title>");
    auto link = client->Get("/web/secret.txt");
    ASSERT_TRUE(link);
    EXPECT_EQ(link->status, 400) << link->body;
    EXPECT_EQ(link->body.find("secret\n"), std::string::npos);
    fs::remove_all(base);
}

}  // namespace
}  // namespace raycastd
