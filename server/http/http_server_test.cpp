#include "server/http/http_server.h"

#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include "tests/support/raw_http.h"

namespace raycastd::server {
namespace {

using namespace std::chrono_literals;

/// An HttpServer on a free loopback port with /health, /echo (the body's size and type) and
/// /slow (sleeps until its client has gone, reporting what the probe said).
class Served {
  public:
    explicit Served(ConnectionLimits limits) : http_(std::move(limits)) {
        http_.Get("/health", [](const httplib::Request&, httplib::Response& res) {
            res.set_content("{\"status\":\"ok\"}", "application/json");
        });
        http_.Post("/echo", [](const httplib::Request& req, httplib::Response& res) {
            res.set_content(
                std::to_string(req.body.size()) + " " + req.get_header_value("Content-Type"),
                "text/plain");
        });
        // Answers before reading its body, as a busy streamed batch does.
        http_.Post("/early", [](const httplib::Request&, httplib::Response& res,
                                const httplib::ContentReader&) {
            res.status = 503;
            res.set_content("{\"error\":{\"code\":\"busy\"}}", "application/json");
        });
        http_.Get("/slow", [this](const httplib::Request&, httplib::Response& res) {
            const ClientProbe probe = HttpServer::current_client();
            const auto until = std::chrono::steady_clock::now() + 5s;
            while (!probe.gone() && std::chrono::steady_clock::now() < until)
                std::this_thread::sleep_for(5ms);
            slow_saw_gone_ = probe.gone();
            res.set_content("done", "text/plain");
        });
        port_ = http_.bind("127.0.0.1", 0);
        thread_ = std::thread([this] { http_.listen_after_bind(); });
        // cpp-httplib's stop() does nothing before the listen loop has started.
        while (!http_.is_running())
            std::this_thread::sleep_for(1ms);
    }
    ~Served() {
        http_.stop();
        thread_.join();
    }
    int port() const { return port_; }
    HttpServer& http() { return http_; }
    std::atomic<bool> slow_saw_gone_{false};

  private:
    HttpServer http_;
    int port_ = 0;
    std::thread thread_;
};

using testing::connect_loopback;
using testing::exchange;
using testing::read_answer;
using testing::send_all;
using testing::status_of;

int connect_to(int port) {
    return connect_loopback(port);
}

/// Milliseconds a fresh client waits for GET /health.
long long health_ms(int port) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string a = exchange(port, "GET /health HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(status_of(a), 200) << a;
    return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() -
                                                                 t0)
        .count();
}

TEST(HttpServer, ServesAKeepAliveConnectionRequestAfterRequest) {
    Served s(ConnectionLimits{});
    const int c = connect_to(s.port());
    for (int i = 0; i < 3; ++i) {
        send_all(c, "GET /health HTTP/1.1\r\nHost: x\r\n\r\n");
        const std::string a = read_answer(c);
        EXPECT_EQ(status_of(a), 200) << a;
        EXPECT_NE(a.find("{\"status\":\"ok\"}"), std::string::npos);
    }
    ::close(c);
}

TEST(HttpServer, IdleConnectionsDoNotStarveANewClient) {
    // More silent half-sent heads than there are threads: each new client evicts the oldest.
    ConnectionLimits limits;
    limits.max_connections = 16;
    limits.max_idle_per_client = 1000;
    Served s(limits);
    std::vector<int> idle;
    for (int i = 0; i < 64; ++i) {
        const int c = connect_to(s.port());
        send_all(c, "POST /echo HTTP/1.1\r\nHost: x\r\n");
        idle.push_back(c);
    }
    std::this_thread::sleep_for(200ms);
    EXPECT_LT(health_ms(s.port()), 2000);
    EXPECT_GT(s.http().stats().evictions, 0u);
    for (int c : idle)
        ::close(c);
}

TEST(HttpServer, OneAddressHoldsABoundedNumberOfIdleConnections) {
    ConnectionLimits limits;
    limits.max_idle_per_client = 8;
    Served s(limits);
    std::vector<int> idle;
    for (int i = 0; i < 20; ++i)
        idle.push_back(connect_to(s.port()));
    std::this_thread::sleep_for(300ms);
    EXPECT_LE(s.http().stats().idle_connections, 8u);
    EXPECT_LT(health_ms(s.port()), 2000);
    for (int c : idle)
        ::close(c);
}

TEST(HttpServer, AHeadDribbledSlowerThanTheHeaderTimeoutIsDropped) {
    ConnectionLimits limits;
    limits.header_timeout = 600ms;
    Served s(limits);
    const int c = connect_to(s.port());
    send_all(c, "GET /health HTTP/1.1\r\n");
    const auto t0 = std::chrono::steady_clock::now();
    bool closed = false;
    for (int i = 0; i < 30 && !closed; ++i) {
        send_all(c, "X-Dribble: 1\r\n");  // a line every 100 ms, never the blank line
        pollfd p{c, POLLIN, 0};
        if (::poll(&p, 1, 100) > 0) {
            char b;
            closed = ::recv(c, &b, 1, 0) <= 0;
        }
    }
    EXPECT_TRUE(closed);
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 2500ms);
    EXPECT_GE(s.http().stats().timeouts, 1u);
    ::close(c);
}

TEST(HttpServer, MalformedContentLengthIsAnsweredNotWaitedFor) {
    Served s(ConnectionLimits{});
    const std::string negative =
        exchange(s.port(), "POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: -5\r\n\r\nabc");
    EXPECT_EQ(status_of(negative), 400) << negative;
    EXPECT_NE(negative.find("\"invalid_request\""), std::string::npos);
    EXPECT_NE(negative.find("Connection: close"), std::string::npos);

    const std::string huge = exchange(
        s.port(),
        "POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 12345678901234567890123\r\n\r\n");
    EXPECT_EQ(status_of(huge), 413) << huge;
    EXPECT_NE(huge.find("\"too_large\""), std::string::npos);

    const std::string twice =
        exchange(s.port(),
                 "POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 3\r\nContent-Length: 5\r\n\r\n"
                 "abcde");
    EXPECT_EQ(status_of(twice), 400) << twice;
    EXPECT_NE(twice.find("two different Content-Length"), std::string::npos);

    const std::string smuggle = exchange(s.port(),
                                         "POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 3\r\n"
                                         "Transfer-Encoding: chunked\r\n\r\n0\r\n\r\n");
    EXPECT_EQ(status_of(smuggle), 400) << smuggle;
}

TEST(HttpServer, ABodyOverTheLimitIsRefusedBeforeItIsRead) {
    ConnectionLimits limits;
    limits.head.max_body_bytes = 1000;
    Served s(limits);
    const auto t0 = std::chrono::steady_clock::now();
    // Claims 1 GB and sends none of it: answered at once, not after a read timeout.
    const std::string a =
        exchange(s.port(), "POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 1000000000\r\n\r\n");
    EXPECT_EQ(status_of(a), 413) << a;
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 1500ms);
}

TEST(HttpServer, LongUrlsAndHeadsGetTheirStatusesAsJson) {
    Served s(ConnectionLimits{});
    const std::string url =
        exchange(s.port(), "GET /" + std::string(100'000, 'a') + " HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(status_of(url), 414) << url.substr(0, 200);
    EXPECT_NE(url.find("\"too_large\""), std::string::npos);
    const std::string url9k =
        exchange(s.port(), "GET /" + std::string(9000, 'a') + " HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(status_of(url9k), 414) << url9k.substr(0, 200);
    const std::string header = exchange(
        s.port(), "GET / HTTP/1.1\r\nHost: x\r\nX-Big: " + std::string(20000, 'b') + "\r\n\r\n");
    EXPECT_EQ(status_of(header), 431) << header.substr(0, 200);
}

TEST(HttpServer, AFormEncodedBodyIsReadWholeAsPlainText) {
    Served s(ConnectionLimits{});
    const std::string body(200'000, 'x');  // cpp-httplib alone refuses forms over 8 KiB
    const std::string a = exchange(
        s.port(),
        "POST /echo HTTP/1.1\r\nHost: x\r\nContent-Type: application/x-www-form-urlencoded\r\n"
        "Content-Length: " +
            std::to_string(body.size()) + "\r\n\r\n" + body);
    EXPECT_EQ(status_of(a), 200) << a.substr(0, 300);
    EXPECT_NE(a.find("200000 text/plain"), std::string::npos) << a.substr(0, 300);
}

TEST(HttpServer, AHalfClosedClientGetsItsAnswer) {
    Served s(ConnectionLimits{});
    for (int i = 0; i < 20; ++i) {
        const int c = connect_to(s.port());
        send_all(c, "POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 4\r\n\r\nabcd");
        ::shutdown(c, SHUT_WR);
        const std::string a = read_answer(c);
        EXPECT_EQ(status_of(a), 200) << "try " << i << ": " << a;
        ::close(c);
    }
}

TEST(HttpServer, BodiesOverTheBudgetAreBusyWithRetryAfter) {
    ConnectionLimits limits;
    limits.body_budget_bytes = 1000;
    Served s(limits);
    // The first upload is admitted (alone it may use the whole budget) and stalls half-sent.
    const int first = connect_to(s.port());
    send_all(first, "POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 900\r\n\r\nabc");
    std::this_thread::sleep_for(200ms);
    const std::string second =
        exchange(s.port(), "POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 900\r\n\r\n" +
                               std::string(900, 'y'));
    EXPECT_EQ(status_of(second), 503) << second;
    EXPECT_NE(second.find("Retry-After: 1"), std::string::npos);
    EXPECT_NE(second.find("\"busy\""), std::string::npos);
    ::close(first);
    std::this_thread::sleep_for(200ms);
    // Once the first has gone, its share is free again.
    const std::string third =
        exchange(s.port(), "POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 900\r\n\r\n" +
                               std::string(900, 'y'));
    EXPECT_EQ(status_of(third), 200) << third;
    // The server gives the share back just after it has written the answer.
    for (int i = 0; i < 100 && s.http().stats().body_bytes_in_flight != 0; ++i)
        std::this_thread::sleep_for(10ms);
    EXPECT_EQ(s.http().stats().body_bytes_in_flight, 0u);
}

TEST(HttpServer, AnAnswerBeforeTheBodyIsReadEndsTheConnection) {
    // Without it, the unread body is parsed as the next request on the connection.
    Served s(ConnectionLimits{});
    const int c = connect_to(s.port());
    send_all(c, "POST /early HTTP/1.1\r\nHost: x\r\nContent-Length: 40000\r\n\r\n" +
                    std::string(40000, 'G') + "GET /health HTTP/1.1\r\nHost: x\r\n\r\n");
    const std::string first = read_answer(c);
    EXPECT_EQ(status_of(first), 503) << first;
    // The connection is closed rather than reading 'GGGG…' as a request.
    const std::string rest = read_answer(c, 2000ms);
    EXPECT_TRUE(rest.empty()) << rest.substr(0, 200);
    ::close(c);
}

TEST(HttpServer, AHandlerSeesItsClientGo) {
    Served s(ConnectionLimits{});
    const int c = connect_to(s.port());
    send_all(c, "GET /slow HTTP/1.1\r\nHost: x\r\n\r\n");
    std::this_thread::sleep_for(100ms);
    ::close(c);
    for (int i = 0; i < 100 && !s.slow_saw_gone_; ++i)
        std::this_thread::sleep_for(20ms);
    EXPECT_TRUE(s.slow_saw_gone_);
}

// cpp-httplib built without CPPHTTPLIB_USE_POLL answers a connection whose descriptor is past
// FD_SETSIZE with a 500 (it cannot select() on it); Debian's is built with it, and our own loop
// polls, so --max-connections is not held under 1024.
TEST(HttpServer, ServesADescriptorPastFdSetsize) {
    rlimit lim{};
    ASSERT_EQ(::getrlimit(RLIMIT_NOFILE, &lim), 0);
    constexpr rlim_t kWanted = FD_SETSIZE + 64;
    if (lim.rlim_cur < kWanted) {
        if (lim.rlim_max != RLIM_INFINITY && lim.rlim_max < kWanted)
            GTEST_SKIP() << "this process may open only " << lim.rlim_max << " descriptors";
        rlimit raised = lim;
        raised.rlim_cur = kWanted;
        ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &raised), 0);
    }
    Served s(ConnectionLimits{});
    // Fill the descriptors below FD_SETSIZE, so that the server's next accept() gets one past it.
    std::vector<int> fillers;
    while (fillers.empty() || (fillers.back() >= 0 && fillers.back() < FD_SETSIZE))
        fillers.push_back(::open("/dev/null", O_RDONLY));
    const int c = connect_to(s.port());
    send_all(c, "GET /health HTTP/1.1\r\nHost: x\r\n\r\n");
    const std::string a = read_answer(c);
    ::close(c);
    for (int fd : fillers)
        ::close(fd);
    EXPECT_GT(c, FD_SETSIZE) << "the server's socket is the one after the client's";
    EXPECT_EQ(status_of(a), 200) << a;
    EXPECT_NE(a.find("{\"status\":\"ok\"}"), std::string::npos) << a;
    ::setrlimit(RLIMIT_NOFILE, &lim);
}

TEST(HttpServer, StopsWithConnectionsStillOpen) {
    auto s = std::make_unique<Served>(ConnectionLimits{});
    std::vector<int> open;
    for (int i = 0; i < 8; ++i)
        open.push_back(connect_to(s->port()));
    const auto t0 = std::chrono::steady_clock::now();
    s.reset();
    EXPECT_LT(std::chrono::steady_clock::now() - t0, 3000ms);
    for (int c : open)
        ::close(c);
}

}  // namespace
}  // namespace raycastd::server
