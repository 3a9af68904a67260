// App's routes as the 405 answer reads them: the methods each known path has, and no methods
// for a path no route matches.

#include "server/app.h"

#include <gtest/gtest.h>

namespace raycastd::server {
namespace {

TEST(App, AllowedMethodsFollowTheInstalledRoutes) {
    Config c;
    c.port = 0;
    App app(c);
    EXPECT_EQ(app.allowed_methods("/v1/health"), "GET, HEAD");
    EXPECT_EQ(app.allowed_methods("/v1/openapi.json"), "GET, HEAD");
    EXPECT_EQ(app.allowed_methods("/v1/intersect"), "POST");
    EXPECT_EQ(app.allowed_methods("/v1/scenes"), "GET, HEAD, POST");
    EXPECT_EQ(app.allowed_methods("/v1/scenes/sc_0123abc"), "GET, HEAD, DELETE");
    EXPECT_EQ(app.allowed_methods("/v1/scenes/sc_0123abc/intersect"), "POST");
    EXPECT_EQ(app.allowed_methods("/v1/jobs/jb_1"), "GET, HEAD, DELETE");
    EXPECT_EQ(app.allowed_methods("/v1/jobs/jb_1/image"), "GET, HEAD");
    // Not ours: no route matches, so a request there is 404 not_found whatever its method.
    EXPECT_EQ(app.allowed_methods("/v1/nothing"), "");
    EXPECT_EQ(app.allowed_methods("/v1/scenes/"), "");
    EXPECT_EQ(app.allowed_methods("/v1/scenes/sc-1"), "");
    EXPECT_EQ(app.allowed_methods("/v1/scenes/a/b"), "");
    EXPECT_EQ(app.allowed_methods("/v1/health/"), "");
    EXPECT_EQ(app.allowed_methods("/v1/openapiXjson"), "");
}

}  // namespace
}  // namespace raycastd::server
