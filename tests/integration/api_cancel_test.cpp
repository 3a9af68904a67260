// Abandoned work stops, and --request-timeout-s, against the real raycastd binary
// (server/request_cancel.h). A client that disconnects from a large render, a streamed binary
// batch or a JSON batch must leave the server idle within half a second: its CPU time (utime +
// stime of /proc/PID/stat) stops growing and its resident memory comes back down. A request
// past the time limit is 503 timeout (a streamed answer already under way is cut short), and
// the server goes on serving. Each test prints what it measured.

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "tests/support/raw_http.h"
#include "tests/support/server_process.h"

namespace raycastd {
namespace {

// ASan's allocator keeps freed memory in its quarantine (256 MB by default) instead of handing
// it back, so under it resident memory says nothing of what the server freed: the release
// build checks it. The server under test is built with RAYCASTD_SERVER_SANITIZE's sanitizers;
// this client is not (cmake/test_code.cmake).
constexpr bool kAllocatorHandsMemoryBack =
    std::string_view(RAYCASTD_SERVER_SANITIZE).find("address") == std::string_view::npos;

using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;
using testing::connect_loopback;
using testing::send_all;
using testing::ServerProcess;

// --- The server process, seen from /proc ------------------------------------------------------

struct ProcSample {
    double cpu_s = 0;           ///< utime + stime
    std::size_t rss_bytes = 0;  ///< resident set
};

ProcSample sample(pid_t pid) {
    std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    std::getline(f, line);
    // Fields after "(comm)": state is field 3, utime 14, stime 15, rss 24 (pages).
    std::istringstream rest(line.substr(line.rfind(')') + 2));
    std::vector<std::string> fields;
    for (std::string s; rest >> s;)
        fields.push_back(s);
    ProcSample out;
    if (fields.size() < 22)
        return out;
    const double tick = static_cast<double>(::sysconf(_SC_CLK_TCK));
    out.cpu_s = (std::stod(fields[11]) + std::stod(fields[12])) / tick;
    out.rss_bytes = std::stoull(fields[21]) * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
    return out;
}

/// Seconds from `since` until the process's CPU time stopped growing: once some 200 ms have
/// passed in which it used at most 20 ms of CPU (two clock ticks), the time of the first sample
/// (every 10 ms) that had reached the CPU time it then has. nullopt if it is not quiet within
/// `limit`.
std::optional<double> seconds_until_idle(pid_t pid, Clock::time_point since,
                                         std::chrono::milliseconds limit) {
    struct Point {
        Clock::time_point at;
        double cpu;
    };
    std::vector<Point> seen;
    while (Clock::now() - since < limit + 200ms) {
        seen.push_back({Clock::now(), sample(pid).cpu_s});
        for (const Point& p : seen) {
            if (seen.back().at - p.at >= 200ms && seen.back().cpu - p.cpu <= 0.0201) {
                for (const Point& q : seen) {
                    if (q.cpu >= seen.back().cpu - 1e-9)
                        return std::chrono::duration<double>(q.at - since).count();
                }
            }
        }
        std::this_thread::sleep_for(10ms);
    }
    return std::nullopt;
}

double mb(std::size_t bytes) {
    return static_cast<double>(bytes) / (1 << 20);
}

// --- Scenes and requests -----------------------------------------------------------------------

/// Registers a scene (a document, or a model file of `content_type`) and returns its id.
std::string register_scene(const ServerProcess& server, const std::string& body,
                           const std::string& content_type = "application/json") {
    auto res = server.client()->Post("/v1/scenes", body, content_type);
    EXPECT_TRUE(res);
    if (!res)
        return "";
    EXPECT_TRUE(res->status == 200 || res->status == 201) << res->body;
    return Json::parse(res->body).at("id").get<std::string>();
}

/// Twenty-five mirror-like spheres on a 5 × 5 grid over a reflecting floor, lit by two point
/// lights: every camera ray spawns shadow and reflected rays.
std::string reflective_spheres() {
    Json objects = Json::array();
    for (int i = 0; i < 25; ++i) {
        objects.push_back({{"type", "sphere"},
                           {"center", {(i % 5) * 2.5 - 5.0, 1.0, (i / 5) * 2.5 + 8.0}},
                           {"radius", 1.0},
                           {"material", "mirror"}});
    }
    objects.push_back({{"type", "triangle"},
                       {"vertices", {{-50, 0, -50}, {50, 0, -50}, {0, 0, 80}}},
                       {"material", "mirror"}});
    const Json doc = {
        {"objects", objects},
        {"materials",
         {{"mirror",
           {{"diffuse", {0.5, 0.4, 0.3}}, {"specular", {0.5, 0.5, 0.5}}, {"reflectivity", 0.5}}}}},
        {"lights",
         {{{"type", "point"}, {"position", {5, 10, 0}}, {"intensity", {0.8, 0.8, 0.8}}},
          {{"type", "point"}, {"position", {-5, 8, 4}}, {"intensity", {0.4, 0.4, 0.4}}}}},
        {"camera", {{"position", {0, 4, -6}}, {"look_at", {0, 1, 12}}, {"fov_y_deg", 50}}}};
    return doc.dump();
}

/// A latitude-longitude unit sphere as OBJ text: `rings` × `segments` quads, two triangles each
/// (rings 200, segments 200: 80,000 triangles, those at the poles degenerate).
std::string uv_sphere_obj(int rings, int segments) {
    std::ostringstream os;
    os.precision(9);
    const double pi = 3.14159265358979323846;
    for (int r = 0; r <= rings; ++r) {
        for (int s = 0; s < segments; ++s) {
            const double theta = pi * r / rings, phi = 2 * pi * s / segments;
            os << "v " << std::sin(theta) * std::cos(phi) << ' ' << std::cos(theta) << ' '
               << std::sin(theta) * std::sin(phi) << '\n';
        }
    }
    const auto v = [&](int r, int s) { return r * segments + (s % segments) + 1; };
    for (int r = 0; r < rings; ++r) {
        for (int s = 0; s < segments; ++s) {
            os << "f " << v(r, s) << ' ' << v(r + 1, s) << ' ' << v(r + 1, s + 1) << '\n';
            os << "f " << v(r, s) << ' ' << v(r + 1, s + 1) << ' ' << v(r, s + 1) << '\n';
        }
    }
    return os.str();
}

/// `n` large triangles with corners uniform in [-1, 1]³, as OBJ text: their boxes all overlap,
/// so a BVH cannot cull them and a ray through the cube tests nearly every one (2,000 of them
/// make a ray cost tens of microseconds at precision exact).
std::string tangle_obj(int n) {
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::ostringstream os;
    os.precision(9);
    for (int i = 0; i < 3 * n; ++i)
        os << "v " << u(rng) << ' ' << u(rng) << ' ' << u(rng) << '\n';
    for (int i = 0; i < n; ++i)
        os << "f " << 3 * i + 1 << ' ' << 3 * i + 2 << ' ' << 3 * i + 3 << '\n';
    return os.str();
}

/// n float32 records `ox oy oz dx dy dz tmin tmax`: origins uniform in [-1.5, 1.5]³,
/// directions uniform on the sphere.
std::string random_ray_records(std::size_t n) {
    std::mt19937_64 rng(13);
    std::uniform_real_distribution<float> u(-1.5f, 1.5f);
    std::normal_distribution<float> g(0.0f, 1.0f);
    std::string out(n * 32, '\0');
    for (std::size_t i = 0; i < n; ++i) {
        float d[3] = {g(rng), g(rng), g(rng)};
        const float len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) + 1e-30f;
        const float rec[8] = {u(rng),     u(rng),     u(rng), d[0] / len,
                              d[1] / len, d[2] / len, 0.0f,   1e30f};
        std::memcpy(&out[i * 32], rec, 32);
    }
    return out;
}

/// A raw HTTP/1.1 POST with a Content-Length.
std::string post(const std::string& path, const std::string& content_type,
                 const std::string& body) {
    return "POST " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: " + content_type +
           "\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
}

/// What one disconnect did to the server.
struct Abandoned {
    double working_cpu_s;          ///< CPU the server used while the client waited
    std::optional<double> stop_s;  ///< disconnect → CPU stopped growing
    std::size_t rss_before, rss_working, rss_after;
};

/// Sends `request` on a fresh connection, waits `wait` (the server working on it), closes the
/// connection without reading a byte and watches the server go idle.
Abandoned abandon(const ServerProcess& server, const std::string& request,
                  std::chrono::milliseconds wait = 300ms) {
    Abandoned a{};
    const ProcSample before = sample(server.pid());
    a.rss_before = before.rss_bytes;
    const int s = connect_loopback(server.port());
    send_all(s, request);
    std::this_thread::sleep_for(wait);
    const ProcSample working = sample(server.pid());
    a.working_cpu_s = working.cpu_s - before.cpu_s;
    a.rss_working = working.rss_bytes;
    ::close(s);
    const auto closed = Clock::now();
    a.stop_s = seconds_until_idle(server.pid(), closed, 5s);
    a.rss_after = sample(server.pid()).rss_bytes;
    // The answer's buffers are freed once the writer sees the connection gone, which on a busy
    // machine can come after the CPU has gone quiet (one run under ctest -j2 sampled 218 MB
    // there; 35 MB alone): the memory is asked for again for up to 2 s, not only once.
    const auto deadline = Clock::now() + 2s;
    while (kAllocatorHandsMemoryBack && a.rss_after >= a.rss_before + (64u << 20) &&
           Clock::now() < deadline) {
        std::this_thread::sleep_for(20ms);
        a.rss_after = sample(server.pid()).rss_bytes;
    }
    return a;
}

void report(const char* what, const Abandoned& a) {
    std::printf(
        "[ measured ] %s: %.2f s of CPU while the client waited; disconnect -> CPU stop %s s; "
        "RSS %.0f MB before, %.0f MB working, %.0f MB after\n",
        what, a.working_cpu_s, a.stop_s ? std::to_string(*a.stop_s).substr(0, 5).c_str() : "never",
        mb(a.rss_before), mb(a.rss_working), mb(a.rss_after));
}

/// The server still answers.
void expect_serving(const ServerProcess& server) {
    auto res = server.client()->Get("/v1/health");
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 200);
}

/// What every disconnect test asks: the work was running, it stopped within half a second of
/// the disconnect, resident memory came back to within 64 MB of where it was (not asked under
/// ASan: kAllocatorHandsMemoryBack), and the server
/// goes on serving.
void expect_stopped(const ServerProcess& server, const char* what, const Abandoned& a) {
    report(what, a);
    EXPECT_GT(a.working_cpu_s, 0.05) << what << ": the work should have been running";
    ASSERT_TRUE(a.stop_s) << what << ": the work went on after its client had gone";
    // Under ASan a tile or block takes several times longer, so the next check comes later.
    EXPECT_LT(*a.stop_s, kAllocatorHandsMemoryBack ? 0.5 : 1.5) << what;
    if (kAllocatorHandsMemoryBack) {
        EXPECT_LT(a.rss_after, a.rss_before + (64u << 20)) << what;
    }
    expect_serving(server);
}

// --- A client that has gone -------------------------------------------------------------------

TEST(Cancel, DisconnectStopsALargeRender) {
    // 4096² at 4 samples a pixel with reflections and shadows: well over 2 s of work here.
    ServerProcess server({"--max-pixels", "100000000"});
    const std::string id = register_scene(server, reflective_spheres());
    const Json body = {{"width", 4096}, {"height", 4096}, {"spp", 4}, {"max_depth", 5}};
    const Abandoned a =
        abandon(server, post("/v1/scenes/" + id + "/render", "application/json", body.dump()));
    // The 192 MB image (the pages its tiles have written so far) is freed.
    expect_stopped(server, "render 4096x4096 spp 4", a);
}

TEST(Cancel, DisconnectStopsAStreamedBinaryBatch) {
    // 4M random rays at precision exact against an 80,000-triangle sphere: ~2 s of tracing
    // here, streamed (closest with a Content-Length); the client sends it all, then goes.
    ServerProcess server;
    const std::string id = register_scene(server, uv_sphere_obj(200, 200), "model/obj");
    const std::string records = random_ray_records(4u << 20);
    const Abandoned a = abandon(
        server, post("/v1/scenes/" + id + "/intersect?mode=closest&precision=exact&dtype=float32",
                     "application/octet-stream", records));
    // 128 MB of records in and 128 MB of answers out: not kept for the next batch.
    expect_stopped(server, "binary batch of 4M rays, streamed", a);
}

TEST(Cancel, ClientGoneAfterTheTracingFreesTheAnswer) {
    // The same batch, but the client goes only once the tracing is over and the server waits,
    // idle, for it to read a 128 MB answer it never reads: the buffers are freed, not pooled
    // (the CI run of 2026-12-01 kept 245 MB after such a client had gone).
    // Where freed memory is not handed back (ASan) only the holding is checked, on a quarter of
    // the batch: 4M exact rays took 18.5 s of the asan stage's serial tail.
    const std::size_t rays = kAllocatorHandsMemoryBack ? 4u << 20 : 1u << 20;
    const std::size_t answer_bytes = rays * 32;  // 32 bytes a float32 closest answer
    ServerProcess server;
    const std::string id = register_scene(server, uv_sphere_obj(200, 200), "model/obj");
    const std::size_t rss_before = sample(server.pid()).rss_bytes;
    const int s = connect_loopback(server.port());
    send_all(s, post("/v1/scenes/" + id + "/intersect?mode=closest&precision=exact&dtype=float32",
                     "application/octet-stream", random_ray_records(rays)));
    ASSERT_TRUE(seconds_until_idle(server.pid(), Clock::now(), 20s)) << "the tracing never ended";
    const std::size_t rss_waiting = sample(server.pid()).rss_bytes;
    ::close(s);
    ASSERT_TRUE(seconds_until_idle(server.pid(), Clock::now(), 5s));
    const std::size_t rss_after = sample(server.pid()).rss_bytes;
    std::printf(
        "[ measured ] answer never read: RSS %.0f MB before, %.0f MB waiting, %.0f MB after\n",
        mb(rss_before), mb(rss_waiting), mb(rss_after));
    EXPECT_GT(rss_waiting, rss_before + answer_bytes) << "the answer should have been held";
    if (kAllocatorHandsMemoryBack) {
        EXPECT_LT(rss_after, rss_before + (64u << 20));
    }
    expect_serving(server);
}

TEST(Cancel, DisconnectStopsAJsonBatch) {
    // 100,000 random rays through 2,000 overlapping triangles at precision exact: seconds of
    // tracing for a 10 MB body that is read in tens of milliseconds.
    ServerProcess server;
    const std::string id = register_scene(server, tangle_obj(2000), "model/obj");
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Json rays = Json::array();
    for (int i = 0; i < 100000; ++i) {
        rays.push_back(
            {{"origin", {u(rng) * 1.5, u(rng) * 1.5, -3.0}}, {"direction", {u(rng), u(rng), 4.0}}});
    }
    const Json body = {{"rays", rays}, {"mode", "closest"}, {"precision", "exact"}};
    const Abandoned a =
        abandon(server, post("/v1/scenes/" + id + "/intersect", "application/json", body.dump()));
    expect_stopped(server, "JSON batch of 100,000 rays through 2,000 triangles", a);
}

TEST(Cancel, GoneClientGetsNoAnswerAndItsConnectionCloses) {
    // A client that shuts down its sending side is taken for gone (as nginx takes it): once
    // its long render has stopped, the server closes the connection without a byte of answer.
    ServerProcess server({"--max-pixels", "100000000"});
    const std::string id = register_scene(server, reflective_spheres());
    const Json body = {{"width", 4096}, {"height", 4096}, {"spp", 4}};
    const int s = connect_loopback(server.port());
    send_all(s, post("/v1/scenes/" + id + "/render", "application/json", body.dump()));
    std::this_thread::sleep_for(300ms);
    ::shutdown(s, SHUT_WR);
    const auto start = Clock::now();
    const std::string answer = testing::read_answer(s, 10s);
    const double took = std::chrono::duration<double>(Clock::now() - start).count();
    ::close(s);
    std::printf(
        "[ measured ] half-closed client of a long render: %zu bytes of answer, "
        "connection closed %.3f s after the shutdown\n",
        answer.size(), took);
    EXPECT_EQ(answer, "");
    EXPECT_LT(took, 1.0) << "the connection should close, not time out";
    expect_serving(server);
}

// --- The time limit ---------------------------------------------------------------------------

TEST(Cancel, RenderPastTheTimeLimitIs503TimeoutAndTheServerGoesOn) {
    ServerProcess server({"--request-timeout-s", "1"});
    const std::string id = register_scene(server, reflective_spheres());
    auto client = server.client();
    const Json big = {{"width", 2048}, {"height", 2048}, {"spp", 4}};
    const auto start = Clock::now();
    auto res = client->Post("/v1/scenes/" + id + "/render", big.dump(), "application/json");
    const double took = std::chrono::duration<double>(Clock::now() - start).count();
    ASSERT_TRUE(res);
    std::printf("[ measured ] render past --request-timeout-s 1: %d after %.2f s: %s\n",
                res->status, took, res->body.c_str());
    EXPECT_EQ(res->status, 503);
    const Json err = Json::parse(res->body).at("error");
    EXPECT_EQ(err.at("code"), "timeout");
    EXPECT_NE(err.at("message").get<std::string>().find("--request-timeout-s 1"),
              std::string::npos);
    EXPECT_LT(took, 1.6);
    // The same connection, then a small render: served as usual.
    auto health = client->Get("/v1/health");
    ASSERT_TRUE(health);
    EXPECT_EQ(health->status, 200);
    const Json small = {{"width", 64}, {"height", 48}};
    auto ok = client->Post("/v1/scenes/" + id + "/render", small.dump(), "application/json");
    ASSERT_TRUE(ok);
    EXPECT_EQ(ok->status, 200);
    EXPECT_EQ(ok->get_header_value("Content-Type"), "image/png");
}

TEST(Cancel, StreamedAnswerPastTheTimeLimitIsCutShort) {
    // The streamed answer's 200 is sent once the last ray has arrived and passed the checks;
    // past the limit the connection closes mid-answer and the client gets a short body. 1M rays
    // (32 MB: in within a few hundred milliseconds even at load 8 on 2 cores, well within the
    // 3 s limit) at exact through 8,000 overlapping triangles: with 1,000 they took 16.8 s at
    // load 4 but only 2.96 s on an idle machine once the engine got faster (issue 17), and the
    // whole answer then fitted in the limit; eight times the triangles is about eight times the
    // work a ray, so the limit falls in the answer on an idle machine and a loaded one alike.
    // (With 256K rays and a 1 s limit the upload itself sometimes ran past the limit at load
    // 7-8: 503 timeout, not the case tested. 1M rays once made the client wait out its 20 s:
    // the server had cut the answer at 3 s, but read_answer parsed the Content-Length by copying
    // the rest of the buffer after every 4 KB recv, quadratic in the answer (raw_http.h).)
    ServerProcess server({"--request-timeout-s", "3"});
    const std::string id = register_scene(server, tangle_obj(8000), "model/obj");
    const std::string records = random_ray_records(1u << 20);
    const auto start = Clock::now();
    const std::string answer = testing::exchange(
        server.port(),
        post("/v1/scenes/" + id + "/intersect?mode=closest&precision=exact&dtype=float32",
             "application/octet-stream", records),
        20s);
    const double took = std::chrono::duration<double>(Clock::now() - start).count();
    const auto head_end = answer.find("\r\n\r\n");
    ASSERT_NE(head_end, std::string::npos) << answer.substr(0, 200);
    const std::string head = answer.substr(0, head_end);
    ASSERT_EQ(head.rfind("HTTP/1.1 200", 0), 0u) << head;
    const std::size_t announced = records.size();  // 32-byte answers for 32-byte rays
    EXPECT_NE(head.find("Content-Length: " + std::to_string(announced)), std::string::npos);
    const std::size_t got = answer.size() - head_end - 4;
    std::printf(
        "[ measured ] streamed answer past --request-timeout-s 3: %zu of %zu bytes, "
        "closed after %.2f s\n",
        got, announced, took);
    EXPECT_LT(got, announced);
    EXPECT_EQ(got % 32, 0u) << "cut at a chunk's end";
    expect_serving(server);
}

}  // namespace
}  // namespace raycastd
