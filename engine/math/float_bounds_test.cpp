#include "engine/math/float_bounds.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

/// Bit patterns compared, so that −0 and +0 and NaNs are told apart.
bool same_double(double a, double b) {
    if (std::isnan(a) || std::isnan(b))
        return std::isnan(a) && std::isnan(b);
    std::uint64_t x, y;
    std::memcpy(&x, &a, sizeof x);
    std::memcpy(&y, &b, sizeof y);
    return x == y;
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
        EXPECT_TRUE(same_double(next_up(v), std::nextafter(v, kInf))) << v;
        EXPECT_TRUE(same_double(next_down(v), std::nextafter(v, -kInf))) << v;
    }
}

}  // namespace
}  // namespace raycastd::engine
