#include "engine/math/float_bounds.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

/// Bit patterns compared, so that −0 and +0 and NaNs are told apart (T float or double).
template <class T>
bool same_bits(T a, T b) {
    if (std::isnan(a) || std::isnan(b))
        return std::isnan(a) && std::isnan(b);
    return std::memcmp(&a, &b, sizeof a) == 0;
}

TEST(FloatBounds, NextUpAndDownStepAsNextafter) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    constexpr double kMax = std::numeric_limits<double>::max();
    constexpr double kMinNormal = std::numeric_limits<double>::min();
    constexpr double kTiny = std::numeric_limits<double>::denorm_min();
    std::vector<double> values = {
        0.0,  -0.0,  kTiny,        -kTiny,   2 * kTiny, kMinNormal, -kMinNormal, kMinNormal - kTiny,
        1.0,  -1.0,  0.1,          -0.1,     1e300,     -1e300,     kMax,        -kMax,
        kInf, -kInf, std::nan(""), 3.0e-310, -7.5e-320, 123456.789, -2.0,        0.5};
    // Powers of two, where the spacing changes on one side.
    for (int e = -1074; e <= 1023; e += 7) {
        values.push_back(std::ldexp(1.0, e));
        values.push_back(-std::ldexp(1.0, e));
    }
    for (double v : values) {
        EXPECT_TRUE(same_bits(next_up(v), std::nextafter(v, kInf))) << v;
        EXPECT_TRUE(same_bits(next_down(v), std::nextafter(v, -kInf))) << v;
    }
}

TEST(FloatBounds, NextFloatUpAndDownStepAsNextafter) {
    constexpr float kInf = std::numeric_limits<float>::infinity();
    constexpr float kMax = std::numeric_limits<float>::max();
    constexpr float kMinNormal = std::numeric_limits<float>::min();
    constexpr float kTiny = std::numeric_limits<float>::denorm_min();
    std::vector<float> values = {0.0f,      -0.0f,      kTiny,         -kTiny,
                                 2 * kTiny, kMinNormal, -kMinNormal,   kMinNormal - kTiny,
                                 1.0f,      -1.0f,      0.1f,          -0.1f,
                                 1e30f,     -1e30f,     kMax,          -kMax,
                                 kInf,      -kInf,      std::nanf(""), 3.0e-40f,
                                 -7.5e-44f, 123456.79f, -2.0f,         0.5f};
    for (int e = -149; e <= 127; e += 3) {
        values.push_back(std::ldexp(1.0f, e));
        values.push_back(-std::ldexp(1.0f, e));
    }
    for (float v : values) {
        EXPECT_TRUE(same_bits(next_up(v), std::nextafter(v, kInf))) << v;
        EXPECT_TRUE(same_bits(next_down(v), std::nextafter(v, -kInf))) << v;
    }
}

// float_up and float_down as they were written with std::nextafter (before 2026-12-06): the
// same floats for doubles on both sides of float's grid, exactly on it, and at its ends.
TEST(FloatBounds, FloatUpAndDownAreTheNearestFloatsOnEachSide) {
    constexpr float kInf = std::numeric_limits<float>::infinity();
    std::vector<double> values = {
        0.0,           -0.0,          1.0,
        -1.0,          0.1,           -0.1,
        1e-45,         -1e-45,        1e-40,
        3.4e38,        -3.4e38,       static_cast<double>(std::numeric_limits<float>::max()),
        1.0 + 0x1p-30, 1.0 - 0x1p-30, -1.0 + 0x1p-30,
        1e-300,        -1e-300};
    std::uint64_t state = 0x9E3779B97F4A7C15ull;
    for (int i = 0; i < 20000; ++i) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        const double m = static_cast<double>(state >> 11) * 0x1p-53;  // [0, 1)
        const int e = static_cast<int>((state >> 3) % 200) - 100;
        values.push_back(((state & 1) ? -1.0 : 1.0) * std::ldexp(1.0 + m, e));
    }
    for (double v : values) {
        const float f = static_cast<float>(v);
        const float up = static_cast<double>(f) < v ? std::nextafter(f, kInf) : f;
        const float down = static_cast<double>(f) > v ? std::nextafter(f, -kInf) : f;
        EXPECT_TRUE(same_bits(float_up(v), up)) << v;
        EXPECT_TRUE(same_bits(float_down(v), down)) << v;
        EXPECT_GE(static_cast<double>(float_up(v)), v);
        EXPECT_LE(static_cast<double>(float_down(v)), v);
    }
}

}  // namespace
}  // namespace raycastd::engine
