#include "server/schema/ray_sax.h"

#include <gtest/gtest.h>

namespace raycastd::server {
namespace {

struct Outcome {
    bool threw = false;
    std::string code, path;
    IntersectRequest req;
};

Outcome dom(const std::string& body) {
    Outcome o;
    try {
        o.req = parse_intersect_request(Json::parse(body), "", 4);
    } catch (const ApiError& e) {
        o.threw = true;
        o.code = e.code;
        o.path = e.path;
    } catch (const Json::exception&) {
        o.threw = true;
        o.code = "bad_json";
    }
    return o;
}

/// The fast path, falling back to the DOM reader as the server does.
Outcome fast(const std::string& body, bool& used_fast) {
    Outcome o;
    try {
        used_fast = parse_intersect_request_fast(body, 4, o.req);
        if (!used_fast) return dom(body);
    } catch (const ApiError& e) {
        used_fast = true;
        o.threw = true;
        o.code = e.code;
        o.path = e.path;
    }
    return o;
}

void expect_same(const std::string& body, bool expect_fast) {
    bool used_fast = false;
    const Outcome a = dom(body), b = fast(body, used_fast);
    EXPECT_EQ(used_fast, expect_fast) << body;
    ASSERT_EQ(a.threw, b.threw) << body;
    EXPECT_EQ(a.code, b.code) << body;
    EXPECT_EQ(a.path, b.path) << body;
    if (a.threw) return;
    ASSERT_EQ(a.req.rays.size(), b.req.rays.size()) << body;
    for (std::size_t i = 0; i < a.req.rays.size(); ++i) {
        EXPECT_EQ(a.req.rays[i].origin, b.req.rays[i].origin);
        EXPECT_EQ(a.req.rays[i].direction, b.req.rays[i].direction);
        EXPECT_EQ(a.req.rays[i].tmin, b.req.rays[i].tmin);
        EXPECT_EQ(a.req.rays[i].tmax, b.req.rays[i].tmax);
    }
    EXPECT_EQ(a.req.options.mode, b.req.options.mode);
    EXPECT_EQ(a.req.options.precision, b.req.options.precision);
    EXPECT_EQ(a.req.options.want_normal, b.req.options.want_normal);
    EXPECT_EQ(a.req.fields.point, b.req.fields.point);
    EXPECT_EQ(a.req.fields.t, b.req.fields.t);
}

TEST(RaySax, SameAnswersAsTheDomReader) {
    // Well-formed bodies take the fast path.
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}]})", true);
    expect_same(R"({"mode":"all","rays":[{"direction":[1,2,3],"tmax":5,"origin":[-1,0.5,2e3],"tmin":-1}],
                    "precision":"exact","fields":["t","object"],"client":{"x":[1,{"y":2}]}})",
                true);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1],"note":"x","extra":[1,[2]]}]})", true);
    expect_same(R"({"rays":[]})", true);
    // Well-formed but invalid: the same errors.
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]},{"origin":[0,0,0],"direction":[0,0,0]}]})",
                true);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1],"tmin":3,"tmax":1}]})", true);
    expect_same(R"({"rays":[], "mode":"nearest"})", true);
    expect_same(R"({"rays":[], "fields":["colour"]})", true);
    // Anything else falls back to the DOM reader and its messages.
    expect_same(R"({"rays":[{"origin":[0,0],"direction":[0,0,1]}]})", false);
    expect_same(R"({"rays":[{"origin":[0,0,0,0],"direction":[0,0,1]}]})", false);
    expect_same(R"({"rays":[{"origin":[0,"x",0],"direction":[0,0,1]}]})", false);
    expect_same(R"({"rays":[{"direction":[0,0,1]}]})", false);
    expect_same(R"({"rays":[[0,0,0]]})", false);
    expect_same(R"({"rays":{}})", false);
    expect_same(R"({"mode":"any"})", false);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}],"mode":3})", false);
    expect_same(R"([1,2])", false);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1e999]}]})", false);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}] trailing)", false);
    expect_same(R"({"rays":[1,2,3,4,5]})", false);
    // Over the ray limit (4 here): the DOM reader reports too_large with the real count.
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]},{"origin":[0,0,0],"direction":[0,0,1]},
                    {"origin":[0,0,0],"direction":[0,0,1]},{"origin":[0,0,0],"direction":[0,0,1]},
                    {"origin":[0,0,0],"direction":[0,0,1]}]})",
                false);
}

}  // namespace
}  // namespace raycastd::server
