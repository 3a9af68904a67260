#include "engine/math/float_bounds.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

/// Bit patterns compared, so that −0 and +0 are told apart; any two NaNs count as the same
/// (libm does not specify a NaN result's sign or payload). Its own, not engine/testing's: math/
/// sits below testing/.
template <class T>
bool same_bits_or_both_nan(T a, T b) {
    return std::memcmp(&a, &b, sizeof a) == 0 || (std::isnan(a) && std::isnan(b));
}

/// next_up and next_down against std::nextafter, for T float or double: on `values`, on zeros,
/// subnormals, the normal range's ends, infinities and a NaN, and on ±2^e for every
/// `exponent_step`-th e from the least subnormal's to the largest (where the spacing changes on
/// one side).
template <class T>
void expect_steps_as_nextafter(std::vector<T> values, int exponent_step) {
    using L = std::numeric_limits<T>;
    const T tiny = L::denorm_min(), min_normal = L::min(), inf = L::infinity();
    values.insert(values.end(),
                  {T(0), -T(0), tiny, -tiny, 2 * tiny, min_normal, -min_normal, min_normal - tiny,
                   T(1), T(-1), T(-2), T(0.5), L::max(), -L::max(), inf, -inf, L::quiet_NaN()});
    for (int e = L::min_exponent - L::digits; e <= L::max_exponent - 1; e += exponent_step) {
        values.push_back(std::ldexp(T(1), e));
        values.push_back(-std::ldexp(T(1), e));
    }
    for (T v : values) {
        EXPECT_TRUE(same_bits_or_both_nan(next_up(v), std::nextafter(v, inf))) << v;
        EXPECT_TRUE(same_bits_or_both_nan(next_down(v), std::nextafter(v, -inf))) << v;
    }
}

TEST(FloatBounds, NextUpAndDownStepAsNextafter) {
    expect_steps_as_nextafter<double>({0.1, -0.1, 1e300, -1e300, 3.0e-310, -7.5e-320, 123456.789},
                                      7);
}

TEST(FloatBounds, NextFloatUpAndDownStepAsNextafter) {
    expect_steps_as_nextafter<float>({0.1f, -0.1f, 1e30f, -1e30f, 3.0e-40f, -7.5e-44f, 123456.79f},
                                     3);
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
        EXPECT_TRUE(same_bits_or_both_nan(float_up(v), up)) << v;
        EXPECT_TRUE(same_bits_or_both_nan(float_down(v), down)) << v;
        EXPECT_GE(static_cast<double>(float_up(v)), v);
        EXPECT_LE(static_cast<double>(float_down(v)), v);
    }
}

}  // namespace
}  // namespace raycastd::engine
