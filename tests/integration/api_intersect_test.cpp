// Intersect on a registered mesh scene (Embree path) over HTTP: JSON and binary agree, every
// mode and precision answers, and bad binary bodies are invalid_ray.

#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <thread>

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <nlohmann/json.hpp>
#include <sys/socket.h>
#include <unistd.h>

#include "engine/testing/scenes.h"
#include "tests/support/encode.h"
#include "tests/support/server_process.h"

namespace raycastd {
namespace {

using Json = nlohmann::json;

struct Intersect : ::testing::Test {
    static void SetUpTestSuite() {
        server_ = new testing::ServerProcess();
        const auto sphere = engine::testing::icosphere_object(3, {0.5, -0.25, 1}, 2);
        Json doc = {{"objects",
                     {{{"type", "sphere"}, {"center", {4, 0, 0}}, {"radius", 1}},
                      {{"type", "mesh"},
                       {"format", "obj"},
                       {"name", "ico"},
                       {"data_base64", testing::base64(testing::to_obj(*sphere.mesh))}}}}};
        auto res = server_->client()->Post("/v1/scenes", doc.dump(), "application/json");
        ASSERT_TRUE(res);
        ASSERT_EQ(res->status, 201) << res->body;
        const Json info = Json::parse(res->body);
        id_ = info.at("id");
        ASSERT_EQ(info.at("triangles"), 1280);
        std::mt19937_64 rng(3);
        std::uniform_real_distribution<double> u(-1, 1);
        for (int i = 0; i < 300; ++i) {
            const double o[3] = {u(rng) * 3, u(rng) * 2.5, -8};
            const double d[3] = {u(rng) * 0.15, u(rng) * 0.15, 1};
            rays_.push_back({o[0], o[1], o[2], d[0], d[1], d[2], 0, 1e30});
        }
    }
    static void TearDownTestSuite() {
        delete server_;
        server_ = nullptr;
    }
    static Json json_rays() {
        Json rays = Json::array();
        for (const auto& r : rays_) {
            rays.push_back({{"origin", {r[0], r[1], r[2]}},
                            {"direction", {r[3], r[4], r[5]}},
                            {"tmin", r[6]},
                            {"tmax", r[7]}});
        }
        return rays;
    }
    template <class F>
    static std::string binary_rays() {
        std::string body;
        for (const auto& r : rays_) {
            for (double v : r) {
                const F f = static_cast<F>(v);
                body.append(reinterpret_cast<const char*>(&f), sizeof f);
            }
        }
        return body;
    }
    static httplib::Result post_binary(const std::string& query, const std::string& body) {
        return server_->client()->Post(("/v1/scenes/" + id_ + "/intersect?" + query).c_str(), body,
                                       "application/octet-stream");
    }
    static testing::ServerProcess* server_;
    static std::string id_;
    static std::vector<std::array<double, 8>> rays_;
};
testing::ServerProcess* Intersect::server_ = nullptr;
std::string Intersect::id_;
std::vector<std::array<double, 8>> Intersect::rays_;

template <class F, class I>
void read_record(const std::string& body, std::size_t i, F (&f)[6], I (&ids)[2]) {
    const std::size_t rec = 2 * sizeof(I) + 6 * sizeof(F);
    const char* p = body.data() + i * rec;
    std::memcpy(&f[0], p, sizeof(F));
    std::memcpy(ids, p + sizeof(F), 2 * sizeof(I));
    std::memcpy(&f[1], p + sizeof(F) + 2 * sizeof(I), 5 * sizeof(F));
}

TEST_F(Intersect, BinaryAndJsonAgreeAtEveryPrecision) {
    for (const char* precision : {"fast", "refined", "exact"}) {
        Json req = {{"rays", json_rays()}, {"precision", precision}};
        auto res = server_->client()->Post(("/v1/scenes/" + id_ + "/intersect").c_str(), req.dump(),
                                           "application/json");
        ASSERT_TRUE(res);
        ASSERT_EQ(res->status, 200) << res->body;
        const Json j = Json::parse(res->body);
        EXPECT_EQ(j.at("precision"), precision);
        auto bin = post_binary(std::string("precision=") + precision + "&dtype=float64",
                               binary_rays<double>());
        ASSERT_TRUE(bin);
        ASSERT_EQ(bin->status, 200) << bin->body;
        EXPECT_EQ(bin->get_header_value("X-Precision"), precision);
        ASSERT_EQ(bin->body.size(), rays_.size() * 56);
        int hits = 0;
        for (std::size_t i = 0; i < rays_.size(); ++i) {
            double f[6];
            std::uint32_t ids[2];
            read_record(bin->body, i, f, ids);
            const Json& h = j.at("hits").at(i);
            if (!h.at("hit").get<bool>()) {
                EXPECT_TRUE(std::isinf(f[0]));
                EXPECT_EQ(ids[0], 0xFFFFFFFFu);
                continue;
            }
            ++hits;
            EXPECT_EQ(f[0], h.at("t").get<double>());
            EXPECT_EQ(ids[0], h.at("object").get<std::uint32_t>());
            EXPECT_EQ(ids[1], h.at("primitive").get<std::uint32_t>());
            EXPECT_EQ(f[1], h.at("barycentric").at(0).get<double>());
            EXPECT_EQ(f[3], h.at("normal").at(0).get<double>());
        }
        EXPECT_GT(hits, 50);
    }
}

TEST_F(Intersect, Float32Binary) {
    auto bin = post_binary("precision=exact&dtype=float32", binary_rays<float>());
    ASSERT_TRUE(bin);
    ASSERT_EQ(bin->status, 200);
    ASSERT_EQ(bin->body.size(), rays_.size() * 32);
    int hits = 0;
    for (std::size_t i = 0; i < rays_.size(); ++i) {
        float f[6];
        std::uint32_t ids[2];
        read_record(bin->body, i, f, ids);
        if (!std::isinf(f[0])) {
            ++hits;
            EXPECT_LT(ids[0], 2u);
            EXPECT_NEAR(f[3] * f[3] + f[4] * f[4] + f[5] * f[5], 1.0f, 1e-5f);
        }
    }
    EXPECT_GT(hits, 50);
}

// ?fields takes the JSON form's names: without `normal` the normals are zeros; an unknown or
// empty name is refused (until 2026-12-05 any text was taken, `normals` asking for normals).
TEST_F(Intersect, BinaryFieldsAreTheJsonNames) {
    const std::string body = binary_rays<float>();
    auto lean = post_binary("precision=exact&fields=t,object", body);
    auto full = post_binary("precision=exact&fields=t,normal", body);
    ASSERT_TRUE(lean && full);
    ASSERT_EQ(lean->status, 200) << lean->body;
    ASSERT_EQ(full->status, 200) << full->body;
    int hits = 0;
    for (std::size_t i = 0; i < rays_.size(); ++i) {
        float a[6], b[6];
        std::uint32_t ia[2], ib[2];
        read_record(lean->body, i, a, ia);
        read_record(full->body, i, b, ib);
        EXPECT_EQ(a[0], b[0]) << i;
        if (std::isinf(a[0]))
            continue;
        ++hits;
        EXPECT_EQ(a[3] * a[3] + a[4] * a[4] + a[5] * a[5], 0.0f) << i;
        EXPECT_NEAR(b[3] * b[3] + b[4] * b[4] + b[5] * b[5], 1.0f, 1e-5f) << i;
    }
    EXPECT_GT(hits, 50);
    for (const char* bad : {"fields=normals", "fields=t,,object", "fields=t%2Cbogus", "fields="}) {
        auto r = post_binary(std::string("precision=exact&") + bad, body);
        ASSERT_TRUE(r);
        EXPECT_EQ(r->status, 400) << bad;
        EXPECT_NE(r->body.find("invalid_request"), std::string::npos) << r->body;
        EXPECT_NE(r->body.find("unknown field"), std::string::npos) << r->body;
    }
}

// A float32 answer cannot write a t beyond FLT_MAX: a ray whose denormal direction puts the
// surface at t ~ 5e45 ends at FLT_MAX in float32 (a miss record, not +inf with an object id),
// while float64 reports the hit.
TEST_F(Intersect, Float32RaysEndAtTheLargestFloat) {
    const float inf = std::numeric_limits<float>::infinity();
    const float tiny = std::numeric_limits<float>::denorm_min();
    const float f32[2][8] = {{0, 0, -8, 0, 0, 1, 0, inf}, {0, 0, -8, 0, 0, tiny, 0, inf}};
    auto a = post_binary("precision=exact&dtype=float32",
                         std::string(reinterpret_cast<const char*>(f32), sizeof f32));
    ASSERT_TRUE(a);
    ASSERT_EQ(a->status, 200) << a->body;
    ASSERT_EQ(a->body.size(), 2u * 32);
    float f[6];
    std::uint32_t ids[2];
    read_record(a->body, 0, f, ids);
    ASSERT_FALSE(std::isinf(f[0])) << "the unit-direction ray along +z should hit the scene";
    read_record(a->body, 1, f, ids);
    EXPECT_TRUE(std::isinf(f[0]));
    EXPECT_EQ(ids[0], 0xFFFFFFFFu);
    EXPECT_EQ(ids[1], 0xFFFFFFFFu);

    const double f64[8] = {
        0, 0, -8, 0, 0, double(tiny), 0, std::numeric_limits<double>::infinity()};
    auto b = post_binary("precision=exact&dtype=float64",
                         std::string(reinterpret_cast<const char*>(f64), sizeof f64));
    ASSERT_TRUE(b);
    ASSERT_EQ(b->status, 200) << b->body;
    double d[6];
    std::uint32_t dids[2];
    read_record(b->body, 0, d, dids);
    EXPECT_GT(d[0], 1e45);
    EXPECT_TRUE(std::isfinite(d[0]));
    EXPECT_NE(dids[0], 0xFFFFFFFFu);
}

TEST_F(Intersect, ModesInBinary) {
    const std::string body = binary_rays<double>();
    auto any = post_binary("mode=any&dtype=float64", body);
    auto count = post_binary("mode=count&dtype=float64&precision=exact", body);
    auto all = post_binary("mode=all&dtype=float64&precision=exact", body);
    ASSERT_TRUE(any && count && all);
    ASSERT_EQ(any->body.size(), rays_.size() * 4);
    ASSERT_EQ(count->body.size(), rays_.size() * 4);
    std::size_t offset = 0;
    for (std::size_t i = 0; i < rays_.size(); ++i) {
        std::uint32_t a, c, n;
        std::memcpy(&a, any->body.data() + 4 * i, 4);
        std::memcpy(&c, count->body.data() + 4 * i, 4);
        std::memcpy(&n, all->body.data() + offset, 4);
        EXPECT_EQ(a, c > 0 ? 1u : 0u) << i;
        EXPECT_EQ(n, c) << i;
        // Rays start outside every object and run to 1e30: crossings come in pairs.
        EXPECT_EQ(c % 2, 0u) << i;
        offset += 4 + n * 56;
    }
    EXPECT_EQ(offset, all->body.size());
}

TEST_F(Intersect, BadBinaryBodiesAreInvalidRay) {
    const std::string good = binary_rays<float>();
    auto expect_invalid = [&](const std::string& body, const std::string& needle) {
        auto res = post_binary("dtype=float32", body);
        ASSERT_TRUE(res);
        EXPECT_EQ(res->status, 400) << res->body;
        const Json e = Json::parse(res->body).at("error");
        EXPECT_EQ(e.at("code"), "invalid_ray");
        EXPECT_NE(e.at("message").get<std::string>().find(needle), std::string::npos) << e;
    };
    expect_invalid(good.substr(0, 40), "not a whole number");
    std::string nan_body = good;
    const float nan = std::nanf("");
    std::memcpy(nan_body.data() + 32 * 7 + 4 * 3, &nan, 4);  // ray 7, dx
    expect_invalid(nan_body, "ray 7");
    std::string zero = good;
    std::memset(zero.data() + 32 * 2 + 12, 0, 12);  // ray 2, direction (0, 0, 0)
    expect_invalid(zero, "ray 2");
    std::string inf = good;
    const float pinf = std::numeric_limits<float>::infinity();
    std::memcpy(inf.data() + 0, &pinf, 4);  // ray 0, ox
    expect_invalid(inf, "ray 0");
    auto bad_dtype = post_binary("dtype=float16", good);
    EXPECT_EQ(Json::parse(bad_dtype->body).at("error").at("code"), "invalid_request");
    EXPECT_EQ(Json::parse(bad_dtype->body).at("error").at("path"), "dtype");
    auto empty_dtype = post_binary("dtype=", good);
    EXPECT_EQ(empty_dtype->status, 400) << empty_dtype->body;
    EXPECT_EQ(Json::parse(empty_dtype->body).at("error").at("path"), "dtype");
    // The server is still there, and so is the scene.
    EXPECT_EQ(post_binary("dtype=float32", good)->status, 200);
}

/// n float32 ray records aimed around the scene, generated like the fixture's rays.
std::string many_float_rays(std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> u(-1, 1);
    std::string body(n * 32, '\0');
    for (std::size_t i = 0; i < n; ++i) {
        const float r[8] = {u(rng) * 6, u(rng) * 4, -8, u(rng) * 0.3f, u(rng) * 0.3f, 1, 0, 1e30f};
        std::memcpy(body.data() + 32 * i, r, sizeof r);
    }
    return body;
}

TEST_F(Intersect, LargeBinaryBatchesAnswerAsSmallOnes) {
    // 153,600 rays: a large body is traced in 65,536-ray chunks while it arrives and answered
    // chunk by chunk (server/intersect/binary_stream.h); 15 requests of 10,240 rays take the
    // whole-batch path. Both cut at multiples of the engine's 1024-ray blocks, so the bytes must
    // agree.
    constexpr std::size_t kSmall = 10240, kCount = 15, n = kSmall * kCount;
    const std::string body = many_float_rays(n, 7);
    for (const char* query : {"mode=closest&precision=fast", "mode=closest&precision=refined",
                              "mode=any&precision=fast", "mode=closest&precision=exact"}) {
        auto large = post_binary(std::string(query) + "&dtype=float32", body);
        ASSERT_TRUE(large);
        ASSERT_EQ(large->status, 200) << large->body;
        std::string small;
        for (std::size_t k = 0; k < kCount; ++k) {
            auto r = post_binary(std::string(query) + "&dtype=float32",
                                 body.substr(k * kSmall * 32, kSmall * 32));
            ASSERT_TRUE(r);
            ASSERT_EQ(r->status, 200);
            small += r->body;
        }
        ASSERT_EQ(large->body.size(), small.size()) << query;
        EXPECT_TRUE(large->body == small) << query;
        EXPECT_EQ(large->get_header_value("X-Mode"),
                  std::string(query).substr(5, 3) == "any" ? "any" : "closest");
    }
}

TEST_F(Intersect, LargeBinaryBatchesWithABadRayAreInvalidRay) {
    constexpr std::size_t n = 200000;
    std::string body = many_float_rays(n, 8);
    const float nan = std::nanf("");
    std::memcpy(body.data() + 32 * 190001 + 16, &nan, 4);  // ray 190001, dy (the last chunk)
    std::memset(body.data() + 32 * 70000 + 12, 0, 12);     // ray 70000, zero direction
    auto res = post_binary("dtype=float32&precision=fast", body);
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 400);
    const Json e = Json::parse(res->body).at("error");
    EXPECT_EQ(e.at("code"), "invalid_ray");
    EXPECT_EQ(e.at("path"), "/rays/70000");
}

TEST_F(Intersect, AClientThatStopsReadingALargeAnswerDoesNotHurtTheServer) {
    const std::string body = many_float_rays(300000, 9);
    for (int i = 0; i < 3; ++i) {
        httplib::Request req;
        req.method = "POST";
        req.path = "/v1/scenes/" + id_ + "/intersect?dtype=float32&precision=refined";
        req.set_header("Content-Type", "application/octet-stream");
        req.body = body;
        std::size_t got = 0;
        req.content_receiver = [&](const char*, std::size_t len, std::uint64_t, std::uint64_t) {
            got += len;
            return false;  // hang up after the first piece of the answer
        };
        auto cut = server_->client()->send(req);
        EXPECT_FALSE(cut);
        EXPECT_GT(got, 0u);
    }
    // Still there, and answering in full.
    auto whole = post_binary("dtype=float32&precision=refined", body);
    ASSERT_TRUE(whole);
    EXPECT_EQ(whole->status, 200);
    EXPECT_EQ(whole->body.size(), 300000u * 32);
}

/// A socket connected to the server on 127.0.0.1.
int connect_to(int port) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0)
        return -1;
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        close(fd);
        return -1;
    }
    return fd;
}

bool send_all(int fd, const std::string& data) {
    std::size_t sent = 0;
    while (sent < data.size()) {
        const ssize_t k = send(fd, data.data() + sent, data.size() - sent, 0);
        if (k <= 0)
            return false;
        sent += static_cast<std::size_t>(k);
    }
    return true;
}

/// The server's resident memory in MB (VmRSS).
double resident_mb(pid_t pid) {
    std::ifstream f("/proc/" + std::to_string(pid) + "/status");
    std::string key;
    while (f >> key) {
        if (key == "VmRSS:") {
            double kb = 0;
            f >> kb;
            return kb / 1024.0;
        }
    }
    return -1;
}

TEST_F(Intersect, MemoryFollowsTheBytesSentNotTheLengthAnnounced) {
    // A client announces 8M rays (256 MB) and sends 6 MB: the server must not size answers for
    // all 8M up front (that would be ~1.3 GB: 64-byte rays, 72-byte hits, 32-byte records).
    const std::size_t announced = 8u << 20;
    const std::string part = many_float_rays(3 * 65536, 10);
    const double before = resident_mb(server_->pid());
    ASSERT_GT(before, 0);
    const int fd = connect_to(server_->port());
    ASSERT_GE(fd, 0);
    const std::string head = "POST /v1/scenes/" + id_ +
                             "/intersect?dtype=float32&precision=fast HTTP/1.1\r\n"
                             "Host: 127.0.0.1\r\nContent-Type: application/octet-stream\r\n"
                             "Content-Length: " +
                             std::to_string(announced * 32) + "\r\n\r\n";
    ASSERT_TRUE(send_all(fd, head));
    ASSERT_TRUE(send_all(fd, part));
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    const double during = resident_mb(server_->pid());
    close(fd);  // and go away
    EXPECT_LT(during - before, 200.0) << "resident " << before << " -> " << during << " MB";
    // Still there, and answering.
    EXPECT_EQ(post_binary("dtype=float32", many_float_rays(100, 11))->status, 200);
}

TEST_F(Intersect, CompressedAndRangedLargeBinaryRequests) {
    const std::string body = many_float_rays(100000, 12);
    auto plain = post_binary("dtype=float32&precision=fast", body);
    ASSERT_TRUE(plain);
    ASSERT_EQ(plain->status, 200);
    // A gzip body (cpp-httplib inflates it; its Content-Length is the compressed size).
    auto client = server_->client();
    client->set_compress(true);
    auto gz =
        client->Post(("/v1/scenes/" + id_ + "/intersect?dtype=float32&precision=fast").c_str(),
                     body, "application/octet-stream");
    ASSERT_TRUE(gz);
    EXPECT_EQ(gz->status, 200) << gz->body.substr(0, 200);
    EXPECT_TRUE(gz->body == plain->body);
    // A Range (cpp-httplib 0.11 applies it to any content provider, the status left at 200):
    // exactly the bytes announced go out, the start of the answer, nothing after them.
    const int fd = connect_to(server_->port());
    ASSERT_GE(fd, 0);
    ASSERT_TRUE(send_all(fd, "POST /v1/scenes/" + id_ +
                                 "/intersect?dtype=float32&precision=fast HTTP/1.1\r\n"
                                 "Host: 127.0.0.1\r\nConnection: close\r\nRange: bytes=0-99\r\n"
                                 "Content-Type: application/octet-stream\r\nContent-Length: " +
                                 std::to_string(body.size()) + "\r\n\r\n" + body));
    std::string got;
    char buf[65536];
    for (ssize_t k; (k = recv(fd, buf, sizeof buf, 0)) > 0;)
        got.append(buf, static_cast<std::size_t>(k));
    close(fd);
    const std::size_t head_end = got.find("\r\n\r\n");
    ASSERT_NE(head_end, std::string::npos);
    const std::string answer = got.substr(head_end + 4);
    const std::size_t cl = got.find("Content-Length: ");
    ASSERT_NE(cl, std::string::npos);
    EXPECT_EQ(std::stoul(got.substr(cl + 16)), answer.size()) << got.substr(0, head_end);
    EXPECT_TRUE(answer == plain->body || answer == plain->body.substr(0, 100))
        << answer.size() << " bytes";
}

/// Registers a scene document on the suite's server and returns its id.
std::string register_scene(testing::ServerProcess& server, const Json& doc) {
    auto res = server.client()->Post("/v1/scenes", doc.dump(), "application/json");
    EXPECT_TRUE(res);
    EXPECT_TRUE(res->status == 201 || res->status == 200) << res->body;
    return Json::parse(res->body).at("id").get<std::string>();
}

std::size_t memory_bytes(testing::ServerProcess& server, const std::string& id) {
    auto res = server.client()->Get(("/v1/scenes/" + id).c_str());
    EXPECT_TRUE(res);
    return Json::parse(res->body).at("memory_bytes").get<std::size_t>();
}

// Queries build BVHs on first use (docs/numerics.md): refined's confirmation of float misses
// the exact one, the first fast query fast's own. The scene's memory_bytes counts each from the
// next request on (the registry takes the scene's bytes anew when a request looks it up), and
// queries that build nothing leave it alone.
TEST_F(Intersect, MemoryBytesCountTheBvhsQueriesBuild) {
    const auto mesh = engine::testing::icosphere_object(2, {0, 0, 40}, 3);
    const std::string id = register_scene(
        *server_, Json{{"objects",
                        {{{"type", "mesh"},
                          {"format", "obj"},
                          {"data_base64", testing::base64(testing::to_obj(*mesh.mesh))}}}}});
    const std::string body = many_float_rays(2048, 9);
    const auto post = [&](const char* precision) {
        auto res = server_->client()->Post(
            ("/v1/scenes/" + id + "/intersect?dtype=float32&precision=" + precision).c_str(), body,
            "application/octet-stream");
        ASSERT_TRUE(res);
        ASSERT_EQ(res->status, 200);
    };
    const std::size_t registered = memory_bytes(*server_, id);
    post("refined");  // its float misses inside the bounds build the exact BVH
    post("refined");
    const std::size_t with_exact = memory_bytes(*server_, id);
    EXPECT_GT(with_exact, registered);
    post("refined");
    EXPECT_EQ(memory_bytes(*server_, id), with_exact);
    post("fast");
    post("refined");
    EXPECT_GT(memory_bytes(*server_, id), with_exact);
}

// A scene wider than float can hold (±1e39) is Embree's, scaled to unit size in its float
// frame: refined and exact answer it exactly, fast answers (its float test cannot resolve
// triangles 1e-9 of the scene, and may miss them). Until 2026-12-05 it was brute force.
TEST_F(Intersect, SceneWiderThanFloatIsAnswered) {
    Json objects = Json::array();
    for (int i = 0; i < 20; ++i) {
        const double x = i % 2 ? 1e39 : -1e39, z = 10.0 + i;
        objects.push_back(
            {{"type", "triangle"},
             {"vertices", {{x - 1e30, -1e30, z}, {x + 1e30, -1e30, z}, {x, 1e30, z}}}});
    }
    const std::string id = register_scene(*server_, Json{{"objects", objects}});
    for (const char* precision : {"fast", "refined", "exact"}) {
        const Json q = {{"rays",
                         {{{"origin", {-1e39, 0, 0}}, {"direction", {0, 0, 1}}},
                          {{"origin", {1e39, 0, 100}}, {"direction", {0, 0, -1}}}}},
                        {"precision", precision}};
        auto res = server_->client()->Post(("/v1/scenes/" + id + "/intersect").c_str(), q.dump(),
                                           "application/json");
        ASSERT_TRUE(res);
        ASSERT_EQ(res->status, 200) << res->body;
        const Json r = Json::parse(res->body);
        EXPECT_EQ(r.at("precision"), precision);
        if (std::string(precision) == "fast")
            continue;
        EXPECT_EQ(r.at("hits").at(0).at("object"), 0) << precision;
        EXPECT_EQ(r.at("hits").at(0).at("t"), 10.0) << precision;
        EXPECT_EQ(r.at("hits").at(1).at("object"), 19) << precision;
        EXPECT_EQ(r.at("hits").at(1).at("t"), 71.0) << precision;
    }
}

// Binary batches on a scene small enough for brute force (no BVH) go through the same
// block-at-a-time path: a streamed 70,000-ray request answers as seven small ones.
TEST_F(Intersect, LargeBinaryBatchesOnABruteForceScene) {
    const std::string id = register_scene(
        *server_, Json{{"objects",
                        {{{"type", "sphere"}, {"center", {0, 0, 10}}, {"radius", 2}},
                         {{"type", "sphere"}, {"center", {3, 1, 12}}, {"radius", 2}}}}});
    constexpr std::size_t kSmall = 10000, kCount = 7;
    const std::string body = many_float_rays(kSmall * kCount, 10);
    const std::string path = "/v1/scenes/" + id + "/intersect?dtype=float32&precision=fast";
    auto large = server_->client()->Post(path.c_str(), body, "application/octet-stream");
    ASSERT_TRUE(large);
    ASSERT_EQ(large->status, 200);
    EXPECT_EQ(large->get_header_value("X-Precision"), "exact");
    std::string small;
    for (std::size_t k = 0; k < kCount; ++k) {
        auto r = server_->client()->Post(path.c_str(), body.substr(k * kSmall * 32, kSmall * 32),
                                         "application/octet-stream");
        ASSERT_TRUE(r);
        ASSERT_EQ(r->status, 200);
        small += r->body;
    }
    ASSERT_EQ(large->body.size(), small.size());
    EXPECT_TRUE(large->body == small);
    std::size_t hits = 0;
    for (std::size_t i = 0; i < kSmall * kCount; ++i) {
        std::uint32_t object;
        std::memcpy(&object, small.data() + 32 * i + 4, 4);
        hits += object != 0xFFFFFFFFu;
    }
    EXPECT_GT(hits, 1000u);
}

}  // namespace
}  // namespace raycastd
