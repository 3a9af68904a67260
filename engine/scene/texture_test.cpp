// Texture sampling against values worked out by hand: the sRGB decode of IEC 61966-2-1, the
// bilinear weights between texel centres, and each glTF wrap mode.

#include "engine/scene/texture.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

/// A width × 1 image whose texel x has every channel = codes[x].
Texture row(const std::vector<std::uint8_t>& codes, TextureWrap wrap = TextureWrap::repeat) {
    auto image = std::make_shared<TextureImage>();
    image->width = static_cast<int>(codes.size());
    image->height = 1;
    for (std::uint8_t c : codes)
        image->rgb.insert(image->rgb.end(), {c, c, c});
    Texture t;
    t.image = image;
    t.wrap_s = t.wrap_t = wrap;
    return t;
}

TEST(Texture, SrgbDecodeFollowsIec61966) {
    EXPECT_EQ(srgb_to_linear(0), 0.0);
    EXPECT_EQ(srgb_to_linear(255), 1.0);
    // 10/255 = 0.0392 is below the 0.04045 knee: the linear segment c/12.92.
    EXPECT_DOUBLE_EQ(srgb_to_linear(10), 10.0 / 255.0 / 12.92);
    // 128/255: ((0.50196 + 0.055)/1.055)^2.4 = 0.21586.
    EXPECT_NEAR(srgb_to_linear(128), 0.2158605, 1e-7);
}

TEST(Texture, TexelCentresGiveTheTexelAndMidpointsTheLinearMean) {
    const Texture t = row({0, 255});
    // Texel x's centre is at u = (x + 0.5)/width.
    EXPECT_DOUBLE_EQ(t.sample(0.25, 0.5).x, 0.0);
    EXPECT_DOUBLE_EQ(t.sample(0.75, 0.5).x, 1.0);
    // Halfway between the centres: the mean of the linear values, not of the codes (filtering
    // in linear light).
    EXPECT_DOUBLE_EQ(t.sample(0.5, 0.5).x, 0.5);
    EXPECT_DOUBLE_EQ(t.sample(0.375, 0.5).x, 0.25);
}

TEST(Texture, WrapModes) {
    const Texture repeat = row({0, 255});
    // u = 1.25 repeats to 0.25 (texel 0); u = 0 lies between texel 1 (wrapped) and texel 0.
    EXPECT_DOUBLE_EQ(repeat.sample(1.25, 0.5).x, 0.0);
    EXPECT_DOUBLE_EQ(repeat.sample(-0.25, 0.5).x, 1.0);
    EXPECT_DOUBLE_EQ(repeat.sample(0.0, 0.5).x, 0.5);
    const Texture clamp = row({0, 255}, TextureWrap::clamp_to_edge);
    EXPECT_DOUBLE_EQ(clamp.sample(0.0, 0.5).x, 0.0);
    EXPECT_DOUBLE_EQ(clamp.sample(7.0, 0.5).x, 1.0);
    EXPECT_DOUBLE_EQ(clamp.sample(-3.0, 0.5).x, 0.0);
    const Texture mirror = row({0, 255}, TextureWrap::mirrored_repeat);
    // [1, 2) is the image mirrored: u = 1.25 is texel 1, u = 1.75 texel 0.
    EXPECT_DOUBLE_EQ(mirror.sample(1.25, 0.5).x, 1.0);
    EXPECT_DOUBLE_EQ(mirror.sample(1.75, 0.5).x, 0.0);
    // At u = 1 the two copies of texel 1 meet, so there is no blend with texel 0.
    EXPECT_DOUBLE_EQ(mirror.sample(1.0, 0.5).x, 1.0);
}

TEST(Texture, NearestTakesTheTexelUnderTheSample) {
    Texture t = row({0, 255, 0});
    t.nearest = true;
    EXPECT_DOUBLE_EQ(t.sample(0.40, 0.5).x, 1.0);
    EXPECT_DOUBLE_EQ(t.sample(0.30, 0.5).x, 0.0);
}

TEST(Texture, RowsRunDownTheImage) {
    auto image = std::make_shared<TextureImage>();
    image->width = 1;
    image->height = 2;
    image->rgb = {255, 0, 0, 0, 0, 255};  // row 0 red, row 1 blue
    Texture t;
    t.image = image;
    t.wrap_t = TextureWrap::clamp_to_edge;
    EXPECT_EQ(t.sample(0.5, 0.1), (Vec3d{1, 0, 0}));  // v = 0 is the first row
    EXPECT_EQ(t.sample(0.5, 0.9), (Vec3d{0, 0, 1}));
}

TEST(Texture, NonFiniteAndHugeCoordinatesStayInside) {
    const Texture t = row({0, 255});
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    EXPECT_TRUE(is_finite(t.sample(nan, nan)));
    EXPECT_TRUE(is_finite(t.sample(inf, -inf)));
    EXPECT_TRUE(is_finite(t.sample(1e300, -1e300)));
    EXPECT_TRUE(is_finite(row({0, 255}, TextureWrap::mirrored_repeat).sample(-1e300, 3e299)));
}

}  // namespace
}  // namespace raycastd::engine
