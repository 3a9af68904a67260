// parse_json: every way a body can fail to be JSON is bad_json, in one message format that
// names the byte offset.

#include "server/schema/json_read.h"

#include <gtest/gtest.h>

namespace raycastd::server {
namespace {

ApiError parse_error(std::string_view body) {
    try {
        parse_json(body);
    } catch (const ApiError& e) {
        return e;
    }
    return ApiError(ErrorCode::internal, "parsed");
}

TEST(ParseJson, ParsesWhatNlohmannParses) {
    EXPECT_EQ(parse_json(R"({"a": [1, 2.5, "x", null, true]})"),
              Json::parse(R"({"a": [1, 2.5, "x", null, true]})"));
    EXPECT_EQ(parse_json(" 7 "), Json(7));
}

TEST(ParseJson, EveryFailureIsBadJsonWithAByteOffset) {
    for (const char* body : {"", "{\"scene\": ", "[1, 2,]", "{nope", R"({"d": [NaN, 0, 1]})",
                             R"({"d": [1e999, 0, 1]})", "{} x"}) {
        const ApiError e = parse_error(body);
        EXPECT_EQ(e.code, ErrorCode::bad_json) << body;
        EXPECT_EQ(std::string(e.what()).rfind("body is not valid JSON: byte ", 0), 0u)
            << body << ": " << e.what();
    }
}

TEST(ParseJson, TheOffsetIsWhereTheErrorIs) {
    EXPECT_NE(std::string(parse_error("[1, 2,]").what()).find("byte 7:"), std::string::npos)
        << parse_error("[1, 2,]").what();
    // The overflowing number is found where it ends, as a syntax error would be.
    const std::string overflow = parse_error(R"({"d": [1e999, 0]})").what();
    EXPECT_NE(overflow.find("byte 12:"), std::string::npos) << overflow;
    EXPECT_NE(overflow.find("1e999"), std::string::npos) << overflow;
}

TEST(ParseJson, NestingIsLimitedBeforeTheDeepPartIsBuilt) {
    const auto nested = [](std::size_t depth) {
        return "{\"objects\": [], \"meta\": " + std::string(depth - 1, '[') +
               std::string(depth - 1, ']') + "}";
    };
    EXPECT_NO_THROW(parse_json(nested(kMaxJsonDepth)));
    const ApiError e = parse_error(nested(kMaxJsonDepth + 1));
    EXPECT_EQ(e.code, ErrorCode::invalid_request) << e.what();
    EXPECT_NE(std::string(e.what()).find("deeper than 256 levels"), std::string::npos);
    // 100,000 levels overflowed the stack when the document was copied or destroyed.
    EXPECT_EQ(parse_error(nested(100'000)).code, ErrorCode::invalid_request);
    EXPECT_FALSE(try_parse_json(nested(100'000)).has_value());
    EXPECT_TRUE(try_parse_json(nested(3)).has_value());
}

}  // namespace
}  // namespace raycastd::server
