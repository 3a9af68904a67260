#pragma once
// Test helper: values compared bit for bit, for tests that claim two computations give the same
// doubles or floats (−0 and +0 told apart, NaNs by their bits).

#include <cstring>
#include <type_traits>

#include "engine/math/ray.h"

namespace raycastd::engine::testing {

/// Whether a and b have the same bit pattern.
template <class T>
bool same_bits(T a, T b) {
    static_assert(std::is_trivially_copyable<T>::value, "compared as bytes");
    return std::memcmp(&a, &b, sizeof a) == 0;
}

/// Whether two hits are the same answer to the bit: every field, the doubles by same_bits.
inline bool same_hit(const Hit& a, const Hit& b) {
    return same_bits(a.t, b.t) && same_bits(a.t_err, b.t_err) && a.object == b.object &&
           a.primitive == b.primitive && same_bits(a.u, b.u) && same_bits(a.v, b.v) &&
           same_bits(a.normal.x, b.normal.x) && same_bits(a.normal.y, b.normal.y) &&
           same_bits(a.normal.z, b.normal.z) && a.front_face == b.front_face &&
           a.on_edge == b.on_edge;
}

}  // namespace raycastd::engine::testing
