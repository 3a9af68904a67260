#include "server/schema/ray_scanner.h"

#include <cstring>
#include <random>

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
        o.req = parse_intersect_request(parse_json(body), "", 4);
    } catch (const ApiError& e) {
        o.threw = true;
        o.code = std::string(to_string(e.code));
        o.path = e.path;
    }
    return o;
}

/// The fast path, falling back to the DOM reader as the server does.
Outcome fast(const std::string& body, bool& used_fast) {
    Outcome o;
    try {
        used_fast = scan_intersect_request(body, 4, o.req);
        if (!used_fast)
            return dom(body);
    } catch (const ApiError& e) {
        used_fast = true;
        o.threw = true;
        o.code = std::string(to_string(e.code));
        o.path = e.path;
    }
    return o;
}

/// expect_fast: 1 the fast path must answer, 0 it must give up, -1 either.
void expect_same(const std::string& body, int expect_fast) {
    bool used_fast = false;
    const Outcome a = dom(body), b = fast(body, used_fast);
    if (expect_fast >= 0) {
        EXPECT_EQ(used_fast, expect_fast == 1) << body;
    }
    ASSERT_EQ(a.threw, b.threw) << body;
    EXPECT_EQ(a.code, b.code) << body;
    EXPECT_EQ(a.path, b.path) << body;
    if (a.threw)
        return;
    ASSERT_EQ(a.req.rays.size(), b.req.rays.size()) << body;
    for (std::size_t i = 0; i < a.req.rays.size(); ++i) {
        // Bit for bit: -0.0 and +0.0 compare equal but trace differently (1/d in slab tests).
        EXPECT_EQ(std::memcmp(&a.req.rays[i], &b.req.rays[i], sizeof(engine::Ray)), 0)
            << body << " ray " << i;
    }
    EXPECT_EQ(a.req.options.mode, b.req.options.mode);
    EXPECT_EQ(a.req.options.precision, b.req.options.precision);
    EXPECT_EQ(a.req.options.want_normal, b.req.options.want_normal);
    EXPECT_EQ(a.req.fields.point, b.req.fields.point);
    EXPECT_EQ(a.req.fields.t, b.req.fields.t);
}

TEST(RayScanner, SameAnswersAsTheDomReader) {
    // Well-formed bodies take the fast path.
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}]})", 1);
    expect_same(
        R"({"mode":"all","rays":[{"direction":[1,2,3],"tmax":5,"origin":[-1,0.5,2e3],"tmin":-1}],
                    "precision":"exact","fields":["t","object"],"client":{"x":[1,{"y":2}]}})",
        true);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1],"note":"x","extra":[1,[2]]}]})",
                1);
    expect_same(R"({"rays":[]})", 1);
    // Well-formed but invalid: the same errors.
    expect_same(
        R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]},{"origin":[0,0,0],"direction":[0,0,0]}]})",
        true);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1],"tmin":3,"tmax":1}]})", 1);
    expect_same(R"({"rays":[], "mode":"nearest"})", 1);
    expect_same(R"({"rays":[], "fields":["colour"]})", 1);
    // Anything else falls back to the DOM reader and its messages.
    expect_same(R"({"rays":[{"origin":[0,0],"direction":[0,0,1]}]})", 0);
    expect_same(R"({"rays":[{"origin":[0,0,0,0],"direction":[0,0,1]}]})", 0);
    expect_same(R"({"rays":[{"origin":[0,"x",0],"direction":[0,0,1]}]})", 0);
    expect_same(R"({"rays":[{"direction":[0,0,1]}]})", 0);
    expect_same(R"({"rays":[[0,0,0]]})", 0);
    expect_same(R"({"rays":{}})", 0);
    expect_same(R"({"mode":"any"})", 0);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}],"mode":3})", 0);
    expect_same(R"([1,2])", 0);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1e999]}]})", 0);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}] trailing)", 0);
    expect_same(R"({"rays":[1,2,3,4,5]})", 0);
    // Numbers exactly as the DOM reader converts them: integers as integers ("-0" is +0.0),
    // the rest correctly rounded; edge cases of the grammar and of the range.
    expect_same(R"({"rays":[{"origin":[-0,-0.0,0e5],"direction":[1E2,-1e-2,9007199254740993]}]})",
                1);
    expect_same(
        R"({"rays":[{"origin":[18446744073709551615,-9223372036854775808,18446744073709551616],
                    "direction":[0.1,0.30000000000000004,4.9406564584124654e-324]}]})",
        true);
    expect_same(R"({"rays":[{"origin":[1e-400,0,0],"direction":[0,0,1]}]})", 0);
    expect_same(R"({"rays":[{"origin":[01,0,0],"direction":[0,0,1]}]})", 0);
    expect_same(R"({"rays":[{"origin":[1.,0,0],"direction":[0,0,1]}]})", 0);
    expect_same(R"({"rays":[{"origin":[+1,0,0],"direction":[0,0,1]}]})", 0);
    expect_same(R"({"rays":[{"origin":[.5,0,0],"direction":[0,0,1]}]})", 0);
    expect_same(R"({"rays":[{"origin":[1e,0,0],"direction":[0,0,1]}]})", 0);
    expect_same(R"({"rays":[{"origin":[NaN,0,0],"direction":[0,0,1]}]})", 0);
    expect_same(R"({"rays":[{"origin":[-,0,0],"direction":[0,0,1]}]})", 0);
    // Whitespace anywhere JSON allows it; duplicate keys: the last one counts, as in the DOM.
    expect_same(
        " \t\r\n{ \"rays\" :\n[ { \"origin\" : [ 0 , 0 , 0 ] , \"direction\":[0,0,1] } ] }\n ",
        true);
    expect_same(
        R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1],"origin":[1,2,3]}],"mode":"any","mode":"all"})",
        true);
    expect_same(
        R"({"rays":[{"origin":[9,9,9],"direction":[0,0,1]}],"rays":[{"origin":[0,0,0],"direction":[1,0,0]}]})",
        true);
    // Strings it does not read as plain ASCII, deep nesting, odd literals: the DOM reader.
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}],"mode":"a\u006ey"})", 0);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}],"note":"h\u00e9"})", 0);
    expect_same("{\"rays\":[{\"origin\":[0,0,0],\"direction\":[0,0,1]}],\"note\":\"h\xc3\xa9\"}",
                0);
    expect_same("\xef\xbb\xbf{\"rays\":[]}", 0);
    expect_same(
        R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}],"x":[true,false,null,{"a":[]}]})",
        true);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}],"x":tru})", 0);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}],"x":)" + std::string(100, '[') +
                    std::string(100, ']') + "}",
                0);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]},]})", 0);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}],})", 0);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}])", 0);
    expect_same(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1],"tmax":null}]})", 0);
    // Over the ray limit (4 here): the DOM reader reports too_large with the real count.
    expect_same(
        R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]},{"origin":[0,0,0],"direction":[0,0,1]},
                    {"origin":[0,0,0],"direction":[0,0,1]},{"origin":[0,0,0],"direction":[0,0,1]},
                    {"origin":[0,0,0],"direction":[0,0,1]}]})",
        false);
}

TEST(RayScanner, MutatedBodiesGetTheDomReadersAnswers) {
    // 3,000 random edits of a well-formed body (bytes replaced by JSON punctuation, digits,
    // signs, exponents, quotes, backslashes or high bytes; bytes deleted or duplicated): the
    // fast path answers exactly what the DOM reader answers, or gives up.
    const std::string base =
        R"({"mode":"closest","rays":[{"origin":[-1.5,0,2e1],"direction":[0,-0.25,1],"tmin":0,)"
        R"("tmax":1e30},{"origin":[3,4,5],"direction":[1,1,1]}],"precision":"exact",)"
        R"("fields":["t","normal"],"x":{"y":[true,null,"s"]}})";
    const std::string alphabet = "{}[],:\"\\-+.eE0123456789 tfn\x80\xff";
    std::mt19937_64 rng(12);
    int fast_answers = 0;
    for (int i = 0; i < 3000; ++i) {
        std::string body = base;
        const int edits = 1 + static_cast<int>(rng() % 3);
        for (int k = 0; k < edits && !body.empty(); ++k) {
            const std::size_t at = rng() % body.size();
            switch (rng() % 3) {
                case 0:
                    body[at] = alphabet[rng() % alphabet.size()];
                    break;
                case 1:
                    body.erase(at, 1);
                    break;
                default:
                    body.insert(at, 1, body[at]);
                    break;
            }
        }
        expect_same(body, -1);
        bool used = false;
        IntersectRequest r;
        try {
            used = scan_intersect_request(body, 4, r);
        } catch (const ApiError&) {
            used = true;
        }
        fast_answers += used;
        if (::testing::Test::HasFailure())
            break;
    }
    // Many edits leave a valid body (a digit for a digit): the fast path must see real work.
    EXPECT_GT(fast_answers, 300);
}

}  // namespace
}  // namespace raycastd::server
