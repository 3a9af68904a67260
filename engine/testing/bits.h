#pragma once
// Test helpers: values compared bit for bit, for tests that claim two computations give the same
// doubles or floats (−0 and +0 told apart, NaNs by their bits).

#include <cmath>
#include <cstring>
#include <type_traits>

namespace raycastd::engine::testing {

/// Whether a and b have the same bit pattern.
template <class T>
bool same_bits(T a, T b) {
    static_assert(std::is_trivially_copyable<T>::value, "compared as bytes");
    return std::memcmp(&a, &b, sizeof a) == 0;
}

/// same_bits, except that any two NaNs count as the same: for comparisons with libm, which does
/// not specify a NaN result's sign or payload.
template <class T>
bool same_bits_or_both_nan(T a, T b) {
    return same_bits(a, b) || (std::isnan(a) && std::isnan(b));
}

}  // namespace raycastd::engine::testing
