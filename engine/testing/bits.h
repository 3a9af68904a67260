#pragma once
// Test helper: values compared bit for bit, for tests that claim two computations give the same
// doubles or floats (−0 and +0 told apart, NaNs by their bits).

#include <cstring>
#include <type_traits>

namespace raycastd::engine::testing {

/// Whether a and b have the same bit pattern.
template <class T>
bool same_bits(T a, T b) {
    static_assert(std::is_trivially_copyable<T>::value, "compared as bytes");
    return std::memcmp(&a, &b, sizeof a) == 0;
}

}  // namespace raycastd::engine::testing
