#pragma once
// Floating-point error bounds as code, in named steps (pbrt-v4 §6.8, "Managing Rounding Error").

#include <cmath>
#include <limits>

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

/// The next representable double above v (v itself for +inf).
inline double next_up(double v) {
    return std::nextafter(v, std::numeric_limits<double>::infinity());
}
/// The next representable double below v (v itself for −inf).
inline double next_down(double v) {
    return std::nextafter(v, -std::numeric_limits<double>::infinity());
}

}  // namespace raycastd::engine
