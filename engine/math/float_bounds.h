#pragma once
// Floating-point error bounds as code, in named steps (pbrt-v4 §6.8, "Managing Rounding Error").

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

namespace raycastd::engine {

/// Unit roundoff of double: half the machine epsilon (Higham 2002, §2.1).
constexpr double kDoubleUnitRoundoff = std::numeric_limits<double>::epsilon() * 0.5;
/// Unit roundoff of float.
constexpr double kFloatUnitRoundoff = std::numeric_limits<float>::epsilon() * 0.5;

/// γₙ = n·u / (1 − n·u): bounds the relative error of n chained roundings
/// (Higham 2002, Lemma 3.1), for double arithmetic.
constexpr double gamma(int n) {
    return (n * kDoubleUnitRoundoff) / (1.0 - n * kDoubleUnitRoundoff);
}
/// γₙ for float arithmetic.
constexpr double gamma_float(int n) {
    return (n * kFloatUnitRoundoff) / (1.0 - n * kFloatUnitRoundoff);
}

/// v as a float, ±infinity beyond float's range: a plain conversion of a finite double above
/// FLT_MAX is undefined behaviour (C++17 [conv.double]), and a scene can be finite in double and
/// still span more than float holds. NaN stays NaN.
inline float to_float(double v) {
    constexpr double kMax = std::numeric_limits<float>::max();
    if (v > kMax)
        return std::numeric_limits<float>::infinity();
    if (v < -kMax)
        return -std::numeric_limits<float>::infinity();
    return static_cast<float>(v);
}

/// 2^−⌊log₂ m⌋ for a positive finite m: the power of two that brings m into [1, 2). Multiplying
/// lengths by it (or by a power of two made from it) is exact, short of results that leave
/// double's normal range; the kernels and frames that rescale extreme lengths use it.
inline double power_to_unit(double m) {
    return std::ldexp(1.0, -std::ilogb(m));
}

/// The power of two that brings a length m into [2⁻²⁵⁰, 2²⁵⁰] (power_to_unit), or 1 when it is
/// there already (or is 0, inf or NaN). A kernel multiplies up to three lengths (n·(v − o), the
/// edge functions times a sheared z; a mesh's cross products of edges): their products then stay
/// far inside double's range. Scaling by a power of two is exact (a part that becomes subnormal
/// rounds, far below the ulp of the rest).
inline double unit_scale(double m) {
    if ((m >= 0x1p-250 && m <= 0x1p250) || !(m > 0.0) || !std::isfinite(m))
        return 1.0;
    return power_to_unit(m);
}

/// The next representable value above v (v itself for +inf and NaN), T float or double, by
/// stepping its bit pattern as pbrt-v4 §6.8.2 does (NextFloatUp): the bits of positive values
/// count up with their value, those of negative ones down. std::nextafter gives the same values
/// (tested in float_bounds_test.cpp) but is a call into libm that GCC does not inline: a
/// renderer spawning rays asks for three a ray (2% of a Duck render, perf), and float_up (below)
/// for every other ray prepare_ray sets up.
template <class T>
inline T next_up(T v) {
    static_assert(std::is_same<T, float>::value || std::is_same<T, double>::value,
                  "next_up steps float or double");
    using Bits = typename std::conditional<sizeof(T) == 4, std::uint32_t, std::uint64_t>::type;
    if (!(v < std::numeric_limits<T>::infinity()))
        return v;
    if (v == T(0))  // both zeros
        return std::numeric_limits<T>::denorm_min();
    Bits bits;
    std::memcpy(&bits, &v, sizeof bits);
    bits = v > T(0) ? bits + 1 : bits - 1;
    std::memcpy(&v, &bits, sizeof bits);
    return v;
}
/// The next representable value below v (v itself for −inf; a NaN stays a NaN, its sign
/// flipped).
template <class T>
inline T next_down(T v) {
    return -next_up(-v);
}

/// The largest float ≤ v: v rounded to the nearest float, stepped down when rounding went up.
/// Lower corners of float boxes that must contain the double box. v must lie within float's
/// range (beyond it the conversion is undefined; use to_float).
inline float float_down(double v) {
    const float f = static_cast<float>(v);
    return static_cast<double>(f) > v ? next_down(f) : f;
}
/// The smallest float ≥ v (see float_down): upper corners of boxes, upper ends of ray ranges.
/// The step is selected without a branch: whether rounding went down is a coin toss, and
/// prepare_ray takes every ray's tfar from here (a misprediction a ray in two).
inline float float_up(double v) {
    const float f = static_cast<float>(v);
    const float up = next_up(f);
    std::uint32_t fb, ub;
    std::memcpy(&fb, &f, sizeof fb);
    std::memcpy(&ub, &up, sizeof ub);
    const std::uint32_t take_up = 0u - static_cast<std::uint32_t>(static_cast<double>(f) < v);
    const std::uint32_t bits = (ub & take_up) | (fb & ~take_up);
    float out;
    std::memcpy(&out, &bits, sizeof out);
    return out;
}

}  // namespace raycastd::engine
