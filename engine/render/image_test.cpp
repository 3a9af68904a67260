#include "engine/render/image.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include <gtest/gtest.h>
#include <stb_image.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace raycastd::engine {
namespace {

Image gradient() {
    Image img(4, 3);
    for (int y = 0; y < 3; ++y) {
        for (int x = 0; x < 4; ++x)
            img.set(x, y, {x / 3.0, y / 2.0, 0.5});
    }
    return img;
}

TEST(Image, SrgbCurve) {
    EXPECT_EQ(srgb_encode(0.0f), 0);
    EXPECT_EQ(srgb_encode(1.0f), 255);
    EXPECT_EQ(srgb_encode(2.0f), 255);
    EXPECT_EQ(srgb_encode(-1.0f), 0);
    // Linear 0.5 is sRGB 0.7354 → 188; 0.2159 → 0.5020 → 128 (mid grey).
    EXPECT_EQ(srgb_encode(0.5f), 188);
    EXPECT_EQ(srgb_encode(0.2159f), 128);
    EXPECT_EQ(srgb_encode(0.001f), 3);  // the linear segment: 12.92 · 0.001 · 255
}

// srgb_encode reads a table built from the formula (image.cpp); it must give the formula's code
// on every float. Below 2^-13 the table answers 0 without looking: the formula's product and
// lround only rise with the value, so the largest float below 2^-13 giving 0 covers them all.
TEST(Image, SrgbTableMatchesTheFormulaOnEveryFloat) {
    auto from_bits = [](std::uint32_t b) {
        float f;
        std::memcpy(&f, &b, sizeof f);
        return f;
    };
    const std::uint32_t first = (127u - 13u) << 23;  // 2^-13
    const std::uint32_t one = 127u << 23;            // 1.0f
    EXPECT_EQ(srgb_encode_formula(from_bits(first - 1)), 0);
    std::atomic<std::uint64_t> wrong{0};
    tbb::parallel_for(tbb::blocked_range<std::uint32_t>(first, one + 1, 1u << 16),
                      [&](const tbb::blocked_range<std::uint32_t>& r) {
                          std::uint64_t n = 0;
                          for (std::uint32_t b = r.begin(); b != r.end(); ++b) {
                              const float v = from_bits(b);
                              n += srgb_encode(v) != srgb_encode_formula(v);
                          }
                          wrong += n;
                      });
    EXPECT_EQ(wrong.load(), 0u);
    for (const float v :
         {0.0f, -0.0f, 1e-45f, 1e-38f, 0x1p-14f, -1.0f, 1.0f, 1.5f,
          std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
          std::numeric_limits<float>::quiet_NaN()})
        EXPECT_EQ(srgb_encode(v), srgb_encode_formula(v)) << v;
}

// The data modes' codes round c · 255 half up without libm: the same as std::lround at every
// half-way point and the few floats either side of it, and the batch form as the single one.
TEST(Image, LinearCodesRoundAsLround) {
    std::vector<float> values;
    for (int k = 0; k < 255; ++k) {
        float v = (k + 0.5f) / 255.0f;
        for (int i = 0; i < 4; ++i)
            v = std::nextafter(v, 0.0f);
        for (int i = 0; i < 9; ++i, v = std::nextafter(v, 1.0f))
            values.push_back(v);
    }
    for (const float v : values)
        ASSERT_EQ(encode_8bit(v, true), std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)) << v;
    values.insert(values.end(), {-1.0f, 2.0f, std::numeric_limits<float>::quiet_NaN(),
                                 std::numeric_limits<float>::infinity(), 0.0f, 1.0f});
    for (const bool linear : {true, false}) {
        std::vector<unsigned char> batch(values.size());
        encode_8bit(values.data(), values.size(), linear, batch.data());
        for (std::size_t i = 0; i < values.size(); ++i)
            ASSERT_EQ(batch[i], encode_8bit(values[i], linear)) << values[i];
    }
}

TEST(Image, PngRoundTripsThroughStb) {
    const Image img = gradient();
    const std::string png = encode_image(img, ImageFormat::png);
    int w = 0, h = 0, n = 0;
    unsigned char* px = stbi_load_from_memory(reinterpret_cast<const unsigned char*>(png.data()),
                                              static_cast<int>(png.size()), &w, &h, &n, 3);
    ASSERT_NE(px, nullptr);
    EXPECT_EQ(w, 4);
    EXPECT_EQ(h, 3);
    EXPECT_EQ(px[0], 0);                  // (0,0) red 0
    EXPECT_EQ(px[3 * 3], 255);            // (3,0) red 1
    EXPECT_EQ(px[2], srgb_encode(0.5f));  // blue 0.5, gamma-encoded
    EXPECT_EQ(px[3 * (2 * 4) + 1], 255);  // (0,2) green 1
    stbi_image_free(px);
    // Data modes skip the curve.
    const std::string linear = encode_image(img, ImageFormat::png, /*linear_8bit=*/true);
    px = stbi_load_from_memory(reinterpret_cast<const unsigned char*>(linear.data()),
                               static_cast<int>(linear.size()), &w, &h, &n, 3);
    ASSERT_NE(px, nullptr);
    EXPECT_EQ(px[2], 128);
    stbi_image_free(px);
}

TEST(Image, PpmHeaderAndSize) {
    const std::string ppm = encode_image(gradient(), ImageFormat::ppm);
    ASSERT_EQ(ppm.rfind("P6\n4 3\n255\n", 0), 0u);
    EXPECT_EQ(ppm.size(), std::string("P6\n4 3\n255\n").size() + 4 * 3 * 3);
}

TEST(Image, PfmIsLinearFloatBottomRowFirst) {
    const Image img = gradient();
    const std::string pfm = encode_image(img, ImageFormat::pfm);
    const std::string header = "PF\n4 3\n-1.0\n";
    ASSERT_EQ(pfm.rfind(header, 0), 0u);
    ASSERT_EQ(pfm.size(), header.size() + 4 * 3 * 3 * sizeof(float));
    float first[3];
    std::memcpy(first, pfm.data() + header.size(), sizeof first);
    EXPECT_EQ(first[1], 1.0f);  // the bottom row (y = 2) comes first: green 1
}

TEST(Image, ExrHasTheOpenExrLayout) {
    const Image img = gradient();
    const std::string exr = encode_image(img, ImageFormat::exr);
    const unsigned char magic[4] = {0x76, 0x2f, 0x31, 0x01};
    ASSERT_EQ(std::memcmp(exr.data(), magic, 4), 0);
    EXPECT_EQ(exr[4], 2);  // version 2, single-part scanline
    const auto header_end = exr.find(std::string("screenWindowWidth\0float\0", 24));
    ASSERT_NE(header_end, std::string::npos);
    // After the header: 3 offsets, then 3 chunks of (y, size, B G R × 4 floats).
    const std::size_t table = header_end + 24 + 4 + 4 + 1;
    EXPECT_EQ(exr.size(), table + 3 * 8 + 3 * (8 + 3 * 4 * 4));
    std::uint64_t first_chunk = 0;
    std::memcpy(&first_chunk, exr.data() + table, 8);
    EXPECT_EQ(first_chunk, table + 3 * 8);
    // Chunk 0: y = 0, then the B channel of row 0 (all 0.5).
    std::int32_t y = -1;
    float b0 = 0;
    std::memcpy(&y, exr.data() + first_chunk, 4);
    std::memcpy(&b0, exr.data() + first_chunk + 8, 4);
    EXPECT_EQ(y, 0);
    EXPECT_EQ(b0, 0.5f);
}

TEST(Image, FormatNames) {
    EXPECT_EQ(image_format_from_name("exr"), ImageFormat::exr);
    EXPECT_FALSE(image_format_from_name("jpeg"));
    EXPECT_STREQ(mime_type(ImageFormat::png), "image/png");
}

}  // namespace
}  // namespace raycastd::engine
