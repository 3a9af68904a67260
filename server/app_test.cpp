// App's routes as the 405 answer reads them: the methods each known path has, and no methods
// for a path no route matches.

#include "server/app.h"

#include <chrono>
#include <thread>

#include <gtest/gtest.h>
#include <sys/socket.h>

#include "tests/support/raw_http.h"

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

using raycastd::testing::body_of;
using raycastd::testing::connect_loopback;
using raycastd::testing::read_answer;
using raycastd::testing::send_all;
using raycastd::testing::status_of;

/// Sends `request` on a fresh connection and reads one answer (std::exchange would be found
/// too, by its std::string argument).
std::string ask(int port, const std::string& request) {
    return raycastd::testing::exchange(port, request);
}

/// An App serving on a free loopback port (memory only) until it goes.
class Running {
  public:
    explicit Running(Config c) : app_(on_any_port(std::move(c))) {
        std::string error;
        EXPECT_TRUE(app_.start(error)) << error;
        port_ = app_.bind();
        thread_ = std::thread([this] { app_.listen_after_bind(); });
        // The listen loop is running once a request is answered (stop() before it starts would
        // do nothing).
        while (status_of(ask(port_, "GET /v1/health HTTP/1.1\r\nHost: x\r\n\r\n")) != 200)
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ~Running() {
        app_.stop();
        thread_.join();
    }
    int port() const { return port_; }

  private:
    static Config on_any_port(Config c) {
        c.port = 0;
        c.log_level = LogLevel::error;
        return c;
    }
    App app_;
    int port_ = 0;
    std::thread thread_;
};

std::string gzip(const std::string& bytes) {
    std::string out;
    httplib::detail::gzip_compressor z;
    z.compress(bytes.data(), bytes.size(), true, [&out](const char* data, std::size_t len) {
        out.append(data, len);
        return true;
    });
    return out;
}

std::string header_of(const std::string& answer, const std::string& name) {
    const std::string head = answer.substr(0, answer.find("\r\n\r\n"));
    const auto at = head.find("\r\n" + name + ": ");
    if (at == std::string::npos)
        return "";
    const auto from = at + name.size() + 4;
    return head.substr(from, head.find("\r\n", from) - from);
}

const std::string kSphere = R"({"objects":[{"type":"sphere","center":[0,0,10],"radius":2}]})";

/// Registers kSphere; its id.
std::string register_sphere(int port, const std::string& auth = "") {
    const std::string a = ask(
        port, "POST /v1/scenes HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n" + auth +
                  "Content-Length: " + std::to_string(kSphere.size()) + "\r\n\r\n" + kSphere);
    EXPECT_EQ(status_of(a), 201) << a;
    const std::string body = body_of(a);
    const auto at = body.find("\"id\":\"") + 6;
    return body.substr(at, body.find('"', at) - at);
}

TEST(App, DecodedBodiesCountAgainstTheBodyLimit) {
    Config c;
    c.limits.max_body_bytes = 1u << 20;
    c.token = "s3cret";
    Running r(c);
    // 8 MiB of OBJ comments in a few KB of gzip: over the limit once inflated, refused as soon
    // as it is, whatever its Content-Length.
    const std::string bomb = gzip(std::string(8u << 20, '#'));
    ASSERT_LT(bomb.size(), 64u << 10);
    const std::string head =
        "POST /v1/scenes HTTP/1.1\r\nHost: x\r\nContent-Type: model/obj\r\n"
        "Content-Encoding: gzip\r\nContent-Length: " +
        std::to_string(bomb.size()) + "\r\n";
    const std::string a = ask(r.port(), head + "Authorization: Bearer s3cret\r\n\r\n" + bomb);
    EXPECT_EQ(status_of(a), 413) << a;
    EXPECT_NE(body_of(a).find("\"too_large\""), std::string::npos) << a;
    EXPECT_NE(body_of(a).find("once decoded"), std::string::npos) << a;
    // A small gzip body is still read (decoded) and registered.
    const std::string obj = gzip("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    const std::string ok =
        ask(r.port(),
            "POST /v1/scenes HTTP/1.1\r\nHost: x\r\nContent-Type: model/obj\r\n"
            "Content-Encoding: gzip\r\nAuthorization: Bearer s3cret\r\nContent-Length: " +
                std::to_string(obj.size()) + "\r\n\r\n" + obj);
    EXPECT_EQ(status_of(ok), 201) << ok;
    // A coding cpp-httplib would not decode (and pass on as the body) is refused.
    const std::string other =
        ask(r.port(),
            "POST /v1/intersect HTTP/1.1\r\nHost: x\r\nContent-Encoding: compress\r\n"
            "Content-Length: 2\r\n\r\n{}");
    EXPECT_EQ(status_of(other), 400) << other;
}

TEST(App, TheTokenIsCheckedBeforeTheBodyIsRead) {
    Config c;
    c.token = "s3cret";
    Running r(c);
    // A head announcing 1 MB and no body: the 401 comes without waiting for it, and says the
    // connection closes (the body was never read).
    const int s = connect_loopback(r.port());
    send_all(s,
             "POST /v1/scenes HTTP/1.1\r\nHost: x\r\nContent-Type: model/obj\r\n"
             "Content-Encoding: gzip\r\nContent-Length: 1000000\r\n\r\n");
    const std::string a = read_answer(s, std::chrono::seconds(3));
    ::close(s);
    EXPECT_EQ(status_of(a), 401) << a;
    EXPECT_EQ(header_of(a, "Connection"), "close") << a;
    // The same for DELETE, and for a path no route takes (404 before its body).
    const int d = connect_loopback(r.port());
    send_all(d, "DELETE /v1/scenes/sc_1 HTTP/1.1\r\nHost: x\r\nContent-Length: 1000000\r\n\r\n");
    EXPECT_EQ(status_of(read_answer(d, std::chrono::seconds(3))), 401);
    ::close(d);
    const int n = connect_loopback(r.port());
    send_all(n, "PUT /v1/nothing HTTP/1.1\r\nHost: x\r\nContent-Length: 1000000\r\n\r\n");
    EXPECT_EQ(status_of(read_answer(n, std::chrono::seconds(3))), 404);
    ::close(n);
}

TEST(App, RangeHeadersAreIgnored) {
    Running r(Config{});
    const std::string full = ask(r.port(), "GET /v1/health HTTP/1.1\r\nHost: x\r\n\r\n");
    for (const char* range : {"bytes=0-3", "bytes=0-,0-,0-", "bytes=99999-", "bytes=x"}) {
        const std::string a =
            ask(r.port(),
                std::string("GET /v1/health HTTP/1.1\r\nHost: x\r\nRange: ") + range + "\r\n\r\n");
        EXPECT_EQ(status_of(a), 200) << range << "\n" << a;
        EXPECT_EQ(body_of(a), body_of(full)) << range;
        EXPECT_EQ(header_of(a, "Content-Range"), "") << range;
        EXPECT_EQ(header_of(a, "Accept-Ranges"), "") << range;
    }
    const std::string head =
        ask(r.port(), "HEAD /v1/health HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
    EXPECT_EQ(header_of(head, "Accept-Ranges"), "") << head;
}

TEST(App, ACutOffIntersectBodyIsRefused) {
    Running r(Config{});
    const std::string id = register_sphere(r.port());
    // One float32 record of the two announced, then the client stops sending.
    const std::string rec(32, '\0');
    const std::string head = "POST /v1/scenes/" + id +
                             "/intersect HTTP/1.1\r\nHost: x\r\n"
                             "Content-Type: application/octet-stream\r\n";
    for (const std::string& request :
         {head + "Content-Length: 64\r\n\r\n" + rec,
          head + "Transfer-Encoding: chunked\r\n\r\n20\r\n" + rec + "\r\n"}) {
        const int s = connect_loopback(r.port());
        send_all(s, request);
        ::shutdown(s, SHUT_WR);
        const std::string a = read_answer(s);
        ::close(s);
        EXPECT_EQ(status_of(a), 400) << a;
        EXPECT_NE(body_of(a).find("\"invalid_request\""), std::string::npos) << a;
    }
}

// A chunked body is read and answered, and its connection closes, saying so: cpp-httplib's chunk
// reader takes a chunk not followed by CRLF as the body's end and reports success, so a
// connection kept open after one (as 75c8f90 did) would read what follows as a request: here a
// GET smuggled behind a two-byte chunk (a helper's review).
TEST(App, AChunkedBodyClosesItsConnection) {
    Running r(Config{});
    const std::string body =
        R"({"scene":)" + kSphere + R"(,"rays":[{"origin":[0,0,0],"direction":[0,0,1]}]})";
    char size[16];
    std::snprintf(size, sizeof(size), "%zx", body.size());
    const std::string head =
        "POST /v1/intersect HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
        "Transfer-Encoding: chunked\r\n\r\n";
    const int s = connect_loopback(r.port());
    send_all(s, head + std::string(size) + "\r\n" + body + "\r\n0\r\n\r\n");
    const std::string a = read_answer(s);
    EXPECT_EQ(status_of(a), 200) << a;
    EXPECT_EQ(header_of(a, "Connection"), "close") << a;
    ::close(s);
    const int t = connect_loopback(r.port());
    send_all(t, head + "2\r\n{}X\r\nGET /v1/scenes HTTP/1.1\r\nHost: x\r\n\r\n");
    const std::string b = read_answer(t);
    EXPECT_EQ(header_of(b, "Connection"), "close") << b;
    EXPECT_EQ(b.find("HTTP/1.1", 1), std::string::npos) << "a second answer: " << b;
    ::close(t);
}

// A POST with neither Content-Length nor chunked framing has an empty body (RFC 9112 §6.3): it
// is answered at once, and the connection goes on (cpp-httplib read to the connection's end,
// waiting out the body's grace period and swallowing the next request as the body).
TEST(App, APostWithoutALengthHasAnEmptyBody) {
    Running r(Config{});
    const int s = connect_loopback(r.port());
    send_all(s, "POST /v1/intersect HTTP/1.1\r\nHost: x\r\n\r\n");
    const std::string a = read_answer(s, std::chrono::seconds(2));
    EXPECT_EQ(status_of(a), 400) << a;  // an empty body is not a query
    EXPECT_NE(a.find("bad_json"), std::string::npos) << a;
    send_all(s, "GET /v1/health HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(status_of(read_answer(s, std::chrono::seconds(2))), 200);
    ::close(s);
}

TEST(App, EveryAnswerHasARequestId) {
    Running r(Config{});
    // A method cpp-httplib's request line does not know: its own 400, before any handler.
    const std::string a = ask(r.port(), "FOO /v1/health HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(status_of(a), 400) << a;
    EXPECT_NE(header_of(a, "X-Request-Id"), "") << a;
    EXPECT_EQ(header_of(a, "Connection"), "close") << a;
    // A header line longer than cpp-httplib reads: 431 too_large, not its bare 400.
    const std::string b =
        ask(r.port(),
            "GET /v1/health HTTP/1.1\r\nHost: x\r\nCookie: " + std::string(8300, 'a') + "\r\n\r\n");
    EXPECT_EQ(status_of(b), 431) << b;
    EXPECT_NE(header_of(b, "X-Request-Id"), "") << b;
}

}  // namespace
}  // namespace raycastd::server
