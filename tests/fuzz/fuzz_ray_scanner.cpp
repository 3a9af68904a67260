// Differential: the intersect body's fast scanner (server/schema/ray_scanner.h) against the DOM
// reader (parse_json + parse_intersect_request), the reference. Whenever the scanner answers,
// the DOM reader must answer the same: the same rays bit for bit (-0.0 is not +0.0), mode,
// precision and fields; or both refuse with the same code at the same JSON pointer. When the
// scanner gives up the server asks the DOM reader, so any answer is fine then. Anything thrown
// that is not an ApiError would be a 500 in the server, and is a failure here too.

#include <cstring>
#include <exception>

#include "server/api_error.h"
#include "server/schema/query_doc.h"
#include "server/schema/ray_scanner.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

using namespace raycastd;
using server::ApiError;
using server::IntersectRequest;

/// Small enough that the fuzzer reaches the limit with a few rays.
constexpr std::size_t kMaxRays = 8;

struct Outcome {
    enum { answered, refused, gave_up } kind = answered;
    server::ErrorCode code = server::ErrorCode::internal;
    std::string path, message;
    IntersectRequest req;
};

template <class F>
Outcome run(const char* reader, F&& read) {
    Outcome o;
    try {
        if (!read(o.req))
            o.kind = Outcome::gave_up;
    } catch (const ApiError& e) {
        o.kind = Outcome::refused;
        o.code = e.code;
        o.path = e.path;
        o.message = e.what();
    } catch (const std::exception& e) {
        fuzz::fail(std::string(reader) + " threw a non-API exception (a 500): " + e.what());
    }
    return o;
}

bool same_fields(const server::FieldMask& a, const server::FieldMask& b) {
    return a.t == b.t && a.t_err == b.t_err && a.point == b.point && a.normal == b.normal &&
           a.front_face == b.front_face && a.object == b.object && a.name == b.name &&
           a.primitive == b.primitive && a.barycentric == b.barycentric;
}

void expect_same(const Outcome& fast, const Outcome& dom) {
    if (fast.kind == Outcome::refused) {
        if (dom.kind != Outcome::refused)
            fuzz::fail("the scanner refused (" + fast.message + ") what the DOM reader accepts");
        if (fast.code != dom.code || fast.path != dom.path) {
            fuzz::fail("different errors: scanner " + std::string(server::to_string(fast.code)) +
                       " at '" + fast.path + "' (" + fast.message + "), DOM " +
                       std::string(server::to_string(dom.code)) + " at '" + dom.path + "' (" +
                       dom.message + ")");
        }
        return;
    }
    if (dom.kind != Outcome::answered)
        fuzz::fail("the scanner accepted what the DOM reader refuses: " + dom.message);
    const IntersectRequest &a = fast.req, &b = dom.req;
    if (a.rays.size() != b.rays.size())
        fuzz::fail("different ray counts: " + std::to_string(a.rays.size()) + " and " +
                   std::to_string(b.rays.size()));
    for (std::size_t i = 0; i < a.rays.size(); ++i) {
        if (std::memcmp(&a.rays[i], &b.rays[i], sizeof(engine::Ray)) != 0)
            fuzz::fail("ray " + std::to_string(i) + " differs in its bits");
    }
    if (a.options.mode != b.options.mode || a.options.precision != b.options.precision ||
        a.options.want_normal != b.options.want_normal)
        fuzz::fail("different options");
    if (!same_fields(a.fields, b.fields))
        fuzz::fail("different fields");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string_view body = fuzz::bytes_of(data, size);
    const Outcome fast = run("the scanner", [&](IntersectRequest& out) {
        return server::scan_intersect_request(body, kMaxRays, out);
    });
    if (fast.kind == Outcome::gave_up)
        return 0;
    const Outcome dom = run("the DOM reader", [&](IntersectRequest& out) {
        out = server::parse_intersect_request(server::parse_json(body), "", kMaxRays);
        return true;
    });
    expect_same(fast, dom);
    return 0;
}
