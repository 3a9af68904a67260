#include "server/http/request_head.h"

#include <gtest/gtest.h>

namespace raycastd::server {
namespace {

HeadCheck check(const std::string& head, HeadLimits limits = {}) {
    const auto end = find_head_end(head);
    EXPECT_TRUE(end.has_value()) << head;
    return check_request_head(head, end.value_or(head.size()), limits);
}

TEST(RequestHead, FindsTheEndWithCrLfOrBareLf) {
    EXPECT_EQ(find_head_end("GET / HTTP/1.1\r\nHost: x\r\n\r\nbody"), 27u);
    EXPECT_EQ(find_head_end("GET / HTTP/1.1\nHost: x\n\nbody"), 24u);
    EXPECT_FALSE(find_head_end("GET / HTTP/1.1\r\nHost: x\r\n").has_value());
}

TEST(RequestHead, ReadsMethodTargetAndLength) {
    const auto c = check("POST /v1/scenes?x=1 HTTP/1.1\r\nHost: x\r\ncontent-length: 0012\r\n\r\n");
    ASSERT_TRUE(c.head) << c.error.message;
    EXPECT_EQ(c.head->method, "POST");
    EXPECT_EQ(c.head->target, "/v1/scenes?x=1");
    EXPECT_EQ(c.head->content_length, 12u);
    EXPECT_FALSE(c.head->chunked);
}

TEST(RequestHead, RefusesLengthsThatAreNotDecimalNumbers) {
    for (const char* v : {"-5", "+5", "5 5", "0x10", "", "1e3", "5,5"}) {
        const auto c = check(std::string("POST / HTTP/1.1\r\nContent-Length: ") + v + "\r\n\r\n");
        EXPECT_FALSE(c.head) << v;
        EXPECT_EQ(c.error.status, 400) << v;
        EXPECT_EQ(c.error.code, ErrorCode::invalid_request) << v;
    }
}

TEST(RequestHead, LengthsOverTheLimitAreTooLargeHoweverManyDigits) {
    HeadLimits limits;
    limits.max_body_bytes = 100;
    for (const char* v : {"101", "18446744073709551616", "12345678901234567890123"}) {
        const auto c =
            check(std::string("POST / HTTP/1.1\r\nContent-Length: ") + v + "\r\n\r\n", limits);
        EXPECT_FALSE(c.head) << v;
        EXPECT_EQ(c.error.status, 413) << v;
        EXPECT_EQ(c.error.code, ErrorCode::too_large) << v;
    }
    EXPECT_TRUE(check("POST / HTTP/1.1\r\nContent-Length: 100\r\n\r\n", limits).head);
}

TEST(RequestHead, RefusesContradictoryFraming) {
    EXPECT_FALSE(check("POST / HTTP/1.1\r\nContent-Length: 3\r\nContent-Length: 4\r\n\r\n").head);
    EXPECT_TRUE(check("POST / HTTP/1.1\r\nContent-Length: 3\r\nContent-Length: 3\r\n\r\n").head);
    EXPECT_FALSE(
        check("POST / HTTP/1.1\r\nContent-Length: 3\r\nTransfer-Encoding: chunked\r\n\r\n").head);
    EXPECT_FALSE(check("POST / HTTP/1.1\r\nTransfer-Encoding: gzip\r\n\r\n").head);
    const auto chunked = check("POST / HTTP/1.1\r\nTransfer-Encoding: Chunked\r\n\r\n");
    ASSERT_TRUE(chunked.head);
    EXPECT_TRUE(chunked.head->chunked);
}

TEST(RequestHead, RefusesMalformedLines) {
    EXPECT_FALSE(check("GET /\r\n\r\n").head);
    EXPECT_FALSE(check("GET / HTTP/1.1 extra\r\n\r\n").head);
    EXPECT_FALSE(check("G(T / HTTP/1.1\r\n\r\n").head);
    EXPECT_FALSE(check("GET x HTTP/1.1\r\n\r\n").head);
    EXPECT_FALSE(check("GET / HTTP/1.1\r\nNo colon here\r\n\r\n").head);
    EXPECT_FALSE(check("GET / HTTP/1.1\r\nName : v\r\n\r\n").head);
    EXPECT_FALSE(check("GET / HTTP/1.1\r\nA: b\r\n folded\r\n\r\n").head);
    EXPECT_EQ(check("GET / HTTP/2.0\r\n\r\n").error.status, 505);
}

TEST(RequestHead, LimitsTheUrlAndTheHead) {
    HeadLimits limits;
    limits.max_target_bytes = 10;
    const auto url = check("GET /" + std::string(20, 'a') + " HTTP/1.1\r\n\r\n", limits);
    EXPECT_EQ(url.error.status, 414);
    EXPECT_EQ(url.error.code, ErrorCode::too_large);
    limits.max_head_bytes = 30;
    const auto head = check("GET / HTTP/1.1\r\nX-A: " + std::string(40, 'b') + "\r\n\r\n", limits);
    EXPECT_EQ(head.error.status, 431);
}

TEST(RequestHead, ReadsAFormContentTypeAsPlainText) {
    const auto c =
        check("POST / HTTP/1.1\r\nContent-Type: application/x-www-form-urlencoded\r\n\r\n");
    ASSERT_TRUE(c.head && c.head->rewritten);
    EXPECT_EQ(*c.head->rewritten, "POST / HTTP/1.1\r\nContent-Type: text/plain\r\n\r\n");
    EXPECT_FALSE(
        check("POST / HTTP/1.1\r\nContent-Type: application/json\r\n\r\n").head->rewritten);
}

TEST(RequestHead, DropsRangeHeaders) {
    // cpp-httplib cut or multiplied any answer by a Range (one copy of it per range).
    const auto c = check(
        "GET /v1/info HTTP/1.1\r\nHost: x\r\nRange: bytes=0-,0-,0-\r\nrange: "
        "bytes=0-1\r\nAccept: */*\r\n\r\n");
    ASSERT_TRUE(c.head && c.head->rewritten);
    EXPECT_EQ(*c.head->rewritten, "GET /v1/info HTTP/1.1\r\nHost: x\r\nAccept: */*\r\n\r\n");
}

TEST(RequestHead, EndsEveryLineInCrlfForTheLibrary) {
    const auto c = check("\r\nGET /v1/health HTTP/1.1\nHost: x\r\nConnection: close\n\n");
    ASSERT_TRUE(c.head && c.head->rewritten);
    EXPECT_EQ(*c.head->rewritten,
              "GET /v1/health HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
}

TEST(RequestHead, RefusesAHeaderLineTheLibraryWouldNotRead) {
    const auto ok = check("GET / HTTP/1.1\r\nCookie: " + std::string(8000, 'a') + "\r\n\r\n");
    EXPECT_TRUE(ok.head);
    const auto c = check("GET / HTTP/1.1\r\nCookie: " + std::string(8300, 'a') + "\r\n\r\n");
    ASSERT_FALSE(c.head);
    EXPECT_EQ(c.error.status, 431);
    EXPECT_EQ(c.error.code, ErrorCode::too_large);
}

TEST(RequestHead, TakesOnlyTheContentCodingsTheLibraryDecodes) {
    const auto gz = check("POST / HTTP/1.1\r\nContent-Encoding: GZip\r\nContent-Length: 3\r\n\r\n");
    ASSERT_TRUE(gz.head && gz.head->rewritten);
    EXPECT_EQ(*gz.head->rewritten,
              "POST / HTTP/1.1\r\nContent-Encoding: gzip\r\nContent-Length: 3\r\n\r\n");
    EXPECT_TRUE(check("POST / HTTP/1.1\r\nContent-Encoding: br\r\n\r\n").head);
    EXPECT_EQ(check("POST / HTTP/1.1\r\nContent-Encoding: compress\r\n\r\n").error.status, 400);
    EXPECT_FALSE(
        check("POST / HTTP/1.1\r\nContent-Encoding: gzip\r\nContent-Encoding: gzip\r\n\r\n").head);
    EXPECT_FALSE(check("POST / HTTP/1.1\r\nContent-Encoding: gzip, br\r\n\r\n").head);
}

}  // namespace
}  // namespace raycastd::server
