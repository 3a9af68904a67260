#include "engine/render/image.h"

#include <cstring>

#include <gtest/gtest.h>
#include <stb_image.h>

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
