// The PNG writer (png.h): files that two decoders read back to the same bytes, checked chunk by
// chunk (CRCs, the zlib stream's Adler-32), the same bytes whatever the threads.

#include "engine/render/png.h"

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <stb_image.h>
#include <tbb/task_arena.h>
#include <zlib.h>

namespace raycastd::engine {
namespace {

/// A test image's bytes: a hash of (x, y, channel) in one part, runs of one colour in another.
std::vector<unsigned char> pattern(int w, int h) {
    std::vector<unsigned char> px(3 * static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t hash = (static_cast<std::uint32_t>(x) * 73856093u) ^
                                           (static_cast<std::uint32_t>(y) * 19349663u) ^
                                           (static_cast<std::uint32_t>(k) * 83492791u);
                px[(static_cast<std::size_t>(y) * w + x) * 3 + k] =
                    x < w / 2 ? static_cast<unsigned char>(hash >> 7)
                              : static_cast<unsigned char>(40 * k + (y / 7) % 3);
            }
    return px;
}

std::string encode(int w, int h, const std::vector<unsigned char>& px) {
    return encode_png_rgb8(w, h, [&](int y, unsigned char* out) {
        std::memcpy(out, &px[3 * static_cast<std::size_t>(w) * y], 3 * static_cast<std::size_t>(w));
    });
}

std::uint32_t be32(const std::string& s, std::size_t at) {
    return (std::uint32_t{static_cast<unsigned char>(s[at])} << 24) |
           (std::uint32_t{static_cast<unsigned char>(s[at + 1])} << 16) |
           (std::uint32_t{static_cast<unsigned char>(s[at + 2])} << 8) |
           std::uint32_t{static_cast<unsigned char>(s[at + 3])};
}

/// A decoder of our own, strict where stb_image is lenient (it checks neither CRCs nor the
/// Adler-32): every chunk's CRC, IHDR's fields, IDAT's zlib stream through zlib's uncompress
/// (which checks the header and the Adler-32), each row's filter type (Sub) undone. Fails the
/// test on any departure; returns the pixels.
std::vector<unsigned char> strict_decode(const std::string& png, int w, int h) {
    EXPECT_EQ(png.compare(0, 8, "\x89PNG\r\n\x1a\n", 8), 0);
    std::size_t at = 8;
    std::string idat;
    std::vector<std::string> order;
    while (at + 12 <= png.size()) {
        const std::uint32_t n = be32(png, at);
        const std::string type = png.substr(at + 4, 4);
        if (at + 12 + n > png.size()) {
            ADD_FAILURE() << "chunk " << type << " runs past the end";
            return {};
        }
        const std::uint32_t crc = static_cast<std::uint32_t>(
            crc32(0, reinterpret_cast<const Bytef*>(&png[at + 4]), 4 + n));
        EXPECT_EQ(crc, be32(png, at + 8 + n)) << type;
        if (type == "IHDR") {
            EXPECT_EQ(n, 13u);
            EXPECT_EQ(be32(png, at + 8), static_cast<std::uint32_t>(w));
            EXPECT_EQ(be32(png, at + 12), static_cast<std::uint32_t>(h));
            EXPECT_EQ(png.compare(at + 16, 5, "\x08\x02\x00\x00\x00", 5), 0);
        }
        if (type == "IDAT")
            idat.append(png, at + 8, n);
        if (order.empty() || order.back() != type)
            order.push_back(type);
        at += 12 + n;
    }
    EXPECT_EQ(at, png.size());
    EXPECT_EQ(order, (std::vector<std::string>{"IHDR", "IDAT", "IEND"}));
    const std::size_t stride = 1 + 3 * static_cast<std::size_t>(w);
    std::vector<unsigned char> raw(stride * h);
    uLongf raw_size = raw.size();
    EXPECT_EQ(
        uncompress(raw.data(), &raw_size, reinterpret_cast<const Bytef*>(idat.data()), idat.size()),
        Z_OK);
    EXPECT_EQ(raw_size, raw.size());
    std::vector<unsigned char> px(3 * static_cast<std::size_t>(w) * h);
    for (int y = 0; y < h; ++y) {
        const unsigned char* r = &raw[stride * y];
        EXPECT_EQ(r[0], 1) << "row " << y;  // Sub
        unsigned char* out = &px[(stride - 1) * y];
        for (std::size_t x = 0; x + 1 < stride; ++x)
            out[x] = static_cast<unsigned char>(r[1 + x] + (x >= 3 ? out[x - 3] : 0));
    }
    return px;
}

// Sizes from one pixel to several bands (a band is ~256 KB of rows: 300 × 1000 makes four, the
// last shorter), a single column, a single row.
TEST(Png, TwoDecodersReadBackTheSameBytes) {
    for (const auto& [w, h] :
         {std::pair{1, 1}, {1, 37}, {53, 1}, {2, 2}, {64, 48}, {300, 1000}, {1024, 257}}) {
        SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h));
        const std::vector<unsigned char> px = pattern(w, h);
        const std::string png = encode(w, h, px);
        EXPECT_EQ(strict_decode(png, w, h), px);
        int dw = 0, dh = 0, n = 0;
        unsigned char* d = stbi_load_from_memory(reinterpret_cast<const unsigned char*>(png.data()),
                                                 static_cast<int>(png.size()), &dw, &dh, &n, 3);
        ASSERT_NE(d, nullptr) << stbi_failure_reason();
        EXPECT_EQ(dw, w);
        EXPECT_EQ(dh, h);
        EXPECT_EQ(std::memcmp(d, px.data(), px.size()), 0);
        stbi_image_free(d);
    }
}

// The bands are fixed by the image's size: one thread and several give the same file.
TEST(Png, SameBytesWhateverTheThreads) {
    const std::vector<unsigned char> px = pattern(700, 900);
    const std::string many = encode(700, 900, px);
    tbb::task_arena one(1);
    std::string single;
    one.execute([&] { single = encode(700, 900, px); });
    EXPECT_EQ(single, many);
}

// Runs of one colour, which the Sub filter makes runs of zeros, deflate to almost nothing: a
// 1024 × 768 image of one colour (2.4 MB of pixels) to under 8 KB.
TEST(Png, UniformRowsCompress) {
    const std::string png = encode_png_rgb8(1024, 768, [](int, unsigned char* out) {
        for (int x = 0; x < 1024; ++x) {
            out[3 * x] = 200;
            out[3 * x + 1] = 120;
            out[3 * x + 2] = 30;
        }
    });
    EXPECT_LT(png.size(), 8192u);
    const std::vector<unsigned char> px = strict_decode(png, 1024, 768);
    EXPECT_EQ(px[3 * (1024 * 767 + 1023) + 2], 30);
}

TEST(Png, RefusesAnEmptyImage) {
    auto row = [](int, unsigned char*) {};
    EXPECT_THROW(encode_png_rgb8(0, 5, row), std::invalid_argument);
    EXPECT_THROW(encode_png_rgb8(5, 0, row), std::invalid_argument);
}

}  // namespace
}  // namespace raycastd::engine
