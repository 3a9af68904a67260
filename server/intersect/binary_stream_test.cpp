// StreamedBatch: a batch traced while its body arrives answers byte for byte what the
// whole-batch path answers, names the lowest bad ray, and cleans up after a client that goes
// away at any point.

#include "server/intersect/binary_stream.h"

#include <cmath>
#include <cstring>
#include <random>

#include <gtest/gtest.h>

#include "engine/testing/scenes.h"
#include "server/api_error.h"
#include "server/intersect/binary_batch.h"
#include "server/request_cancel.h"

namespace raycastd::server {
namespace {

constexpr std::size_t kChunk = StreamedBatch::kChunkRays;

std::shared_ptr<const engine::QueryEngine> scene(bool with_sphere) {
    engine::Scene s;
    s.materials.push_back(engine::Material{});
    s.material_names.push_back("default");
    s.objects.push_back(engine::testing::icosphere_object(3, {0.5, -0.25, 1}, 2));
    if (with_sphere) {
        engine::Object o;
        o.kind = engine::ObjectKind::sphere;
        o.name = "sphere";
        o.sphere = {{4, 0, 0}, 1.0};
        s.objects.push_back(o);
    }
    auto e = engine::QueryEngine::build(std::make_shared<engine::Scene>(std::move(s)));
    EXPECT_TRUE(e.ok());
    return *e;
}

/// n float32 ray records: a mix of rays at the scene (hits), past it and away from it.
std::string ray_body(std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> u(-1, 1);
    std::string body(n * 32, '\0');
    for (std::size_t i = 0; i < n; ++i) {
        const float r[8] = {u(rng) * 6,    u(rng) * 4, -8, u(rng) * 0.3f,
                            u(rng) * 0.3f, 1,          0,  std::numeric_limits<float>::infinity()};
        std::memcpy(body.data() + 32 * i, r, sizeof r);
    }
    return body;
}

/// The whole-batch path's answer (decode_rays, QueryEngine::intersect, encode_results).
std::string whole_batch(const engine::QueryEngine& e, const std::string& body,
                        const engine::QueryOptions& opt) {
    std::vector<engine::Ray> rays;
    decode_rays(body, Dtype::float32, body.size(), rays);
    engine::QueryResult r;
    e.intersect(rays, opt, r);
    std::string out;
    encode_results(r, opt.mode, Dtype::float32, rays.size(), out);
    return out;
}

std::shared_ptr<StreamedBatch> batch_for(const std::shared_ptr<const engine::QueryEngine>& e,
                                         const engine::QueryOptions& opt, std::size_t n) {
    return std::make_shared<StreamedBatch>(e, opt, Dtype::float32, n, std::make_shared<Scratch>());
}

/// Feeds `body` in pieces of `piece` bytes (not a multiple of the record: pieces end inside
/// records, as TCP reads do).
void feed(StreamedBatch& b, const std::string& body, std::size_t piece = 4093) {
    for (std::size_t off = 0; off < body.size(); off += piece) {
        ASSERT_TRUE(b.append(body.data() + off, std::min(piece, body.size() - off)));
    }
}

/// The answer as cpp-httplib's content provider collects it.
std::string streamed(StreamedBatch& b) {
    std::string out;
    while (out.size() < b.answer_bytes()) {
        const bool ok = b.write_answer(out.size(), b.answer_bytes() - out.size(),
                                       [&](const char* p, std::size_t n) {
                                           out.append(p, n);
                                           return true;
                                       });
        if (!ok)
            break;
    }
    return out;
}

TEST(StreamedBatch, AnswersByteForByteAsTheWholeBatch) {
    const std::size_t n = 2 * kChunk + 5000;  // two whole chunks and a partial one
    const std::string body = ray_body(n, 1);
    for (bool sphere : {false, true}) {  // packets (triangles only) and single rays
        const auto e = scene(sphere);
        for (engine::Mode mode : {engine::Mode::closest, engine::Mode::any}) {
            for (engine::Precision p :
                 {engine::Precision::fast, engine::Precision::refined, engine::Precision::exact}) {
                const engine::QueryOptions opt{mode, p, true};
                auto b = batch_for(e, opt, n);
                feed(*b, body);
                b->finish();
                EXPECT_EQ(b->precision(), p);
                const std::string got = streamed(*b);
                const std::string want = whole_batch(*e, body, opt);
                ASSERT_EQ(got.size(), want.size());
                EXPECT_TRUE(got == want) << "mode " << engine::to_string(mode) << ", precision "
                                         << engine::to_string(p) << ", sphere " << sphere;
            }
        }
    }
}

TEST(StreamedBatch, AnswersHaveHitsAndMisses) {
    // The comparison above is only worth something if the rays do both.
    const std::size_t n = kChunk + 10;
    const auto e = scene(false);
    auto b = batch_for(e, {engine::Mode::any, engine::Precision::fast, false}, n);
    feed(*b, ray_body(n, 1));
    b->finish();
    const std::string out = streamed(*b);
    std::size_t hits = 0;
    for (std::size_t i = 0; i < n; ++i) {
        std::uint32_t v;
        std::memcpy(&v, out.data() + 4 * i, 4);
        hits += v;
    }
    EXPECT_GT(hits, n / 10);
    EXPECT_LT(hits, n - n / 10);
}

/// The invalid_ray error finish() throws, or "" if it throws none.
std::string finish_error(StreamedBatch& b) {
    try {
        b.finish();
    } catch (const ApiError& e) {
        return std::string(to_string(e.code)) + " " + e.path;
    }
    return "";
}

TEST(StreamedBatch, TheLowestBadRayIsNamedWhicheverChunkFindsItFirst) {
    const std::size_t n = 3 * kChunk + 100;
    const auto e = scene(false);
    const float nan = std::nanf("");
    for (std::size_t first : {std::size_t(5), kChunk + 7, 3 * kChunk + 99}) {
        std::string body = ray_body(n, 2);
        std::memcpy(body.data() + 32 * first + 12, &nan, 4);  // dx
        if (first + kChunk < n) {
            std::memset(body.data() + 32 * (first + kChunk) + 12, 0, 12);  // zero direction
        }
        auto b = batch_for(e, {engine::Mode::closest, engine::Precision::fast, true}, n);
        feed(*b, body, 1 << 20);
        EXPECT_EQ(finish_error(*b), "invalid_ray /rays/" + std::to_string(first));
    }
}

TEST(StreamedBatch, ABodyShortOfItsLengthIsAnError) {
    const std::size_t n = 2 * kChunk;
    const std::string body = ray_body(n, 3);
    const auto e = scene(false);
    auto b = batch_for(e, {engine::Mode::closest, engine::Precision::fast, true}, n);
    feed(*b, body.substr(0, body.size() / 2 + 17));
    EXPECT_EQ(finish_error(*b), "invalid_request ");
    // Nor does it take more than it announced: the batch is spoilt.
    auto c = batch_for(e, {engine::Mode::closest, engine::Precision::fast, true}, n);
    feed(*c, body);
    EXPECT_FALSE(c->append("x", 1));
    EXPECT_EQ(finish_error(*c), "invalid_request ");
}

TEST(StreamedBatch, AClientThatGoesAwayLeavesNothingRunning) {
    // Dropped while the body arrives, after finish(), and after part of the answer: the
    // destructor waits for running chunks (ASan/UBSan builds would see them touch freed memory).
    const std::size_t n = 4 * kChunk;
    const std::string body = ray_body(n, 4);
    const auto e = scene(false);
    const engine::QueryOptions opt{engine::Mode::closest, engine::Precision::refined, true};
    {
        auto b = batch_for(e, opt, n);
        feed(*b, body.substr(0, body.size() * 3 / 4));
    }
    {
        auto b = batch_for(e, opt, n);
        feed(*b, body);
        b->finish();
    }
    {
        auto b = batch_for(e, opt, n);
        feed(*b, body);
        b->finish();
        std::string first;
        EXPECT_FALSE(b->write_answer(0, b->answer_bytes(), [&](const char* p, std::size_t len) {
            first.assign(p, len);
            return false;  // the connection broke: write_answer says so
        }));
        EXPECT_EQ(first.size(), kChunk * 32);
    }
}

/// The float32 body as float64 records (the same rays: float to double is exact).
std::string as_float64(const std::string& body32) {
    std::string out(body32.size() * 2, '\0');
    for (std::size_t i = 0; i < body32.size() / 4; ++i) {
        float f;
        std::memcpy(&f, body32.data() + 4 * i, 4);
        const double d = f;
        std::memcpy(out.data() + 8 * i, &d, 8);
    }
    return out;
}

// intersect_records (the binary path of both the whole batch and the streamed chunks) answers
// byte for byte what decoding every ray, QueryEngine::intersect and encode_results answer, for
// either dtype, and names the lowest bad ray.
TEST(IntersectRecords, AnswersAsDecodeIntersectAndEncode) {
    const std::string body32 = ray_body(5000, 11);
    // Without the sphere, fast and refined take Embree's packets; with it, single rays.
    for (const auto& e : {scene(false), scene(true)}) {
        for (Dtype dtype : {Dtype::float32, Dtype::float64}) {
            const std::string body = dtype == Dtype::float32 ? body32 : as_float64(body32);
            for (engine::Mode mode : {engine::Mode::closest, engine::Mode::any}) {
                for (engine::Precision p : {engine::Precision::fast, engine::Precision::refined,
                                            engine::Precision::exact}) {
                    const engine::QueryOptions opt{mode, p, true};
                    std::vector<engine::Ray> rays;
                    decode_rays(body, dtype, body.size(), rays);
                    engine::QueryResult r;
                    e->intersect(rays, opt, r);
                    std::string want;
                    encode_results(r, mode, dtype, rays.size(), want);
                    std::string got(want.size(), '\0');
                    EXPECT_EQ(intersect_records(*e, body, dtype, opt, 0, rays.size(), got.data()),
                              rays.size());
                    EXPECT_TRUE(got == want)
                        << engine::to_string(mode) << " " << engine::to_string(p);
                }
            }
        }
    }
    const auto e = scene(true);
    // Two bad rays in different blocks: the lower one is named, whichever block ran first.
    std::string bad = body32;
    const float nan = std::nanf("");
    std::memcpy(bad.data() + 32 * 4500 + 12, &nan, 4);  // direction x of ray 4500
    const float zero[3] = {0, 0, 0};
    std::memcpy(bad.data() + 32 * 1100 + 12, zero, 12);  // ray 1100: zero direction
    std::string out(5000 * 32, '\0');
    EXPECT_EQ(intersect_records(*e, bad, Dtype::float32, {}, 0, 5000, out.data()), 1100u);
    EXPECT_EQ(first_bad_ray(bad, Dtype::float32, 0, 5000), 1100u);
    EXPECT_EQ(first_bad_ray(bad, Dtype::float32, 1101, 5000), 4500u);
    EXPECT_EQ(ray_at(bad, Dtype::float32, 1100).direction, (engine::Vec3d{0, 0, 0}));
}

// No rays (an empty body) is an empty answer with a length: cpp-httplib loops forever on a
// content provider of length 0 (regression: tests/fuzz/regressions/http_routes/).
TEST(BinaryBatch, NoRaysIsAnEmptyBodyNotAProvider) {
    const auto e = scene(false);
    for (engine::Mode mode :
         {engine::Mode::closest, engine::Mode::any, engine::Mode::all, engine::Mode::count}) {
        BinaryQuery q;
        q.options.mode = mode;
        auto scratch = acquire_scratch();
        scratch->body.clear();
        httplib::Response res;
        answer_binary_batch(
            *e, q, std::move(scratch), 16, RequestCancel::for_current_request(Limits{}),
            [](std::uint64_t) {}, res);
        EXPECT_EQ(res.status, 200) << engine::to_string(mode);
        EXPECT_TRUE(res.body.empty());
        EXPECT_FALSE(res.content_provider_) << engine::to_string(mode);
        EXPECT_EQ(res.get_header_value("Content-Type"), "application/octet-stream");
    }
}

// Each answer is charged to the answer budget before its buffer is allocated (closest/any/count:
// the exact size from the ray count), and `all` again at its encoded size; a refused charge
// leaves no answer.
TEST(BinaryBatch, ChargesTheAnswerBeforeAllocatingIt) {
    const auto e = scene(true);
    const std::string body = ray_body(1000, 5);
    for (engine::Mode mode :
         {engine::Mode::closest, engine::Mode::any, engine::Mode::count, engine::Mode::all}) {
        BinaryQuery q;
        q.options.mode = mode;
        auto scratch = acquire_scratch();
        scratch->body = body;
        std::vector<std::uint64_t> charges;
        httplib::Response res;
        answer_binary_batch(
            *e, q, scratch, 1u << 20, RequestCancel::for_current_request(Limits{}),
            [&](std::uint64_t bytes) { charges.push_back(bytes); }, res);
        ASSERT_FALSE(charges.empty()) << engine::to_string(mode);
        EXPECT_EQ(charges.back(), scratch->out.size()) << engine::to_string(mode);
        if (mode != engine::Mode::all) {
            EXPECT_EQ(charges.front(), 1000 * answer_record_bytes(mode, Dtype::float32));
        }
        // Refused: the error goes out, and no answer buffer was filled.
        auto refused = acquire_scratch();
        refused->body = body;
        refused->out.clear();
        httplib::Response busy;
        EXPECT_THROW(answer_binary_batch(
                         *e, q, refused, 1u << 20, RequestCancel::for_current_request(Limits{}),
                         [](std::uint64_t) { throw ApiError(ErrorCode::busy, "over"); }, busy),
                     ApiError);
        EXPECT_TRUE(refused->out.empty()) << engine::to_string(mode);
        EXPECT_FALSE(busy.content_provider_);
    }
}

}  // namespace
}  // namespace raycastd::server
