// The error table: one name and one status per code, the OpenAPI document listing exactly the
// codes of the table, and the one mapping from the engine's codes.

#include "server/api_error.h"

#include <set>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "server/openapi.h"

namespace raycastd::server {
namespace {

constexpr ErrorCode kAll[] = {
    ErrorCode::bad_json,        ErrorCode::invalid_scene,      ErrorCode::invalid_ray,
    ErrorCode::invalid_request, ErrorCode::unsupported_format, ErrorCode::scene_not_found,
    ErrorCode::not_found,       ErrorCode::job_not_found,      ErrorCode::method_not_allowed,
    ErrorCode::too_large,       ErrorCode::model_load_failed,  ErrorCode::busy,
    ErrorCode::timeout,         ErrorCode::unauthorized,       ErrorCode::insufficient_storage,
    ErrorCode::internal,
};

TEST(ApiError, EachCodeHasOneNameAndTheStatusOfTheContract) {
    std::set<std::string_view> names;
    for (ErrorCode c : kAll)
        EXPECT_TRUE(names.insert(to_string(c)).second) << to_string(c);
    EXPECT_EQ(names.size(), std::size(kAll));
    EXPECT_EQ(to_string(ErrorCode::bad_json), "bad_json");
    EXPECT_EQ(http_status_of(ErrorCode::bad_json), 400);
    EXPECT_EQ(http_status_of(ErrorCode::unsupported_format), 400);
    EXPECT_EQ(http_status_of(ErrorCode::scene_not_found), 404);
    EXPECT_EQ(http_status_of(ErrorCode::job_not_found), 404);
    EXPECT_EQ(http_status_of(ErrorCode::method_not_allowed), 405);
    EXPECT_EQ(http_status_of(ErrorCode::too_large), 413);
    EXPECT_EQ(http_status_of(ErrorCode::model_load_failed), 422);
    EXPECT_EQ(http_status_of(ErrorCode::busy), 503);
    EXPECT_EQ(http_status_of(ErrorCode::timeout), 503);
    EXPECT_EQ(http_status_of(ErrorCode::internal), 500);
    std::ostringstream os;
    os << ErrorCode::model_load_failed;
    EXPECT_EQ(os.str(), "model_load_failed");
}

TEST(ApiError, OpenApiListsExactlyTheCodesOfTheTable) {
    const auto doc = nlohmann::json::parse(openapi_document());
    const auto listed = doc.at("components")
                            .at("schemas")
                            .at("Error")
                            .at("properties")
                            .at("error")
                            .at("properties")
                            .at("code")
                            .at("enum")
                            .get<std::set<std::string>>();
    std::set<std::string> table;
    for (ErrorCode c : kAll)
        table.emplace(to_string(c));
    EXPECT_EQ(listed, table);
}

TEST(ApiError, EngineCodesMapOnce) {
    using engine::Code;
    const auto code_of = [](Code c) {
        return from_status(engine::Status::error(c, "m", "/objects/1")).code;
    };
    EXPECT_EQ(code_of(Code::invalid_scene), ErrorCode::invalid_scene);
    EXPECT_EQ(code_of(Code::invalid_ray), ErrorCode::invalid_ray);
    EXPECT_EQ(code_of(Code::invalid_request), ErrorCode::invalid_request);
    EXPECT_EQ(code_of(Code::model_load_failed), ErrorCode::model_load_failed);
    EXPECT_EQ(code_of(Code::unsupported_format), ErrorCode::unsupported_format);
    EXPECT_EQ(code_of(Code::too_large), ErrorCode::too_large);
    // A file a document names that is not there: the document's fault, not a missing endpoint.
    EXPECT_EQ(code_of(Code::not_found), ErrorCode::invalid_scene);
    EXPECT_EQ(code_of(Code::internal), ErrorCode::internal);
    // Work stopped by a request's own token (its time limit).
    EXPECT_EQ(code_of(Code::cancelled), ErrorCode::timeout);
    const ApiError e =
        from_status(engine::Status::error(Code::invalid_scene, "m", "/objects/1"), "/scene");
    EXPECT_EQ(e.path, "/scene/objects/1");
    EXPECT_STREQ(e.what(), "m");
}

TEST(ApiError, BodyCarriesCodeMessageAndPath) {
    const auto body =
        nlohmann::json::parse(error_body(ApiError(ErrorCode::invalid_ray, "bad", "/rays/3")));
    EXPECT_EQ(body, nlohmann::json::parse(
                        R"({"error":{"code":"invalid_ray","message":"bad","path":"/rays/3"}})"));
    const auto no_path = nlohmann::json::parse(error_body(ApiError(ErrorCode::busy, "later")));
    EXPECT_FALSE(no_path.at("error").contains("path"));
    // A NUL from the request (an inline `files` key quoted in the message) does not cut the
    // message short: what() had ended it there ("/objects/0/files/a").
    const std::string key = std::string("/objects/0/files/a") + '\0' + "b.mtl";
    const auto nul = nlohmann::json::parse(
        error_body(ApiError(ErrorCode::invalid_scene, key + ": not a path", key)));
    EXPECT_EQ(nul.at("error").at("message"), key + ": not a path");
    EXPECT_EQ(nul.at("error").at("path"), key);
}

}  // namespace
}  // namespace raycastd::server
