// RequestCancel off a request thread: no client to probe (a default probe is never gone), so
// only the time limit fires it; what a fired token and other Statuses turn into.

#include "server/request_cancel.h"

#include <thread>

#include <gtest/gtest.h>

namespace raycastd::server {
namespace {

TEST(RequestCancel, WithoutALimitOnlyErrorsOfTheirOwnAreThrown) {
    const auto cancel = RequestCancel::for_current_request(Limits{});
    EXPECT_TRUE(cancel.token().can_fire());
    EXPECT_NO_THROW(cancel.check(engine::Status{}));
    EXPECT_NO_THROW(cancel.throw_if_cancelled());
    try {
        cancel.check(engine::Status::error(engine::Code::invalid_ray, "ray 3: bad", "/rays/3"),
                     "/x");
        FAIL() << "no throw";
    } catch (const ApiError& e) {
        EXPECT_EQ(e.code, ErrorCode::invalid_ray);
        EXPECT_EQ(e.path, "/x/rays/3");
    }
}

TEST(RequestCancel, PastTheLimitIsTimeoutNamingIt) {
    Limits limits;
    limits.request_timeout_s = 1;
    const auto cancel = RequestCancel::for_current_request(limits);
    EXPECT_FALSE(cancel.token().cancelled());
    std::this_thread::sleep_for(std::chrono::milliseconds(1010));
    EXPECT_TRUE(cancel.token().cancelled());
    try {
        cancel.check(cancel.token().status());
        FAIL() << "no throw";
    } catch (const ApiError& e) {
        EXPECT_EQ(e.code, ErrorCode::timeout);
        EXPECT_EQ(e.http_status(), 503);
        EXPECT_NE(std::string(e.what()).find("time limit of 1 s (--request-timeout-s 1)"),
                  std::string::npos)
            << e.what();
    }
    // A scene build's own error, once the token has fired, is the timeout too.
    try {
        cancel.guard([]() -> int { throw ApiError(ErrorCode::internal, "cancelled build"); });
        FAIL() << "no throw";
    } catch (const ApiError& e) {
        EXPECT_EQ(e.code, ErrorCode::timeout);
    }
}

}  // namespace
}  // namespace raycastd::server
