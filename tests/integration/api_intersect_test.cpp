// Intersect on a registered mesh scene (Embree path) over HTTP: JSON and binary agree, every
// mode and precision answers, and bad binary bodies are invalid_ray.

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <random>

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
                      {{"type", "mesh"}, {"format", "obj"}, {"name", "ico"},
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
            rays.push_back({{"origin", {r[0], r[1], r[2]}}, {"direction", {r[3], r[4], r[5]}},
                            {"tmin", r[6]}, {"tmax", r[7]}});
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
    // chunk by chunk (server/binary_stream.h); 15 requests of 10,240 rays take the whole-batch
    // path. Both cut at multiples of the engine's 1024-ray blocks, so the bytes must agree.
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
        EXPECT_EQ(large->get_header_value("X-Mode"), std::string(query).substr(5, 3) == "any" ? "any" : "closest");
    }
}

TEST_F(Intersect, LargeBinaryBatchesWithABadRayAreInvalidRay) {
    constexpr std::size_t n = 200000;
    std::string body = many_float_rays(n, 8);
    const float nan = std::nanf("");
    std::memcpy(body.data() + 32 * 190001 + 16, &nan, 4);  // ray 190001, dy (the last chunk)
    std::memset(body.data() + 32 * 70000 + 12, 0, 12);    // ray 70000, zero direction
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

}  // namespace
}  // namespace raycastd
