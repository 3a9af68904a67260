#pragma once
// Shortest round-trip decimal form of a double (std::to_chars): "8", "7.267949192431123",
// "1e+30". Reading the text back gives the same double bit for bit.

#include <charconv>
#include <string>

namespace raycastd::engine {

/// Writes the shortest round-trip form of v into buf (at least 32 bytes); returns the length.
/// Non-finite values are written as "inf", "-inf" or "nan" (callers that emit JSON must not
/// pass them).
inline std::size_t format_shortest(double v, char* buf) {
    if (v == 0.0)
        v = 0.0;  // print −0 as 0: a signed zero only confuses a reader
    auto r = std::to_chars(buf, buf + 32, v);
    return static_cast<std::size_t>(r.ptr - buf);
}

inline std::string format_shortest(double v) {
    char buf[32];
    return std::string(buf, format_shortest(v, buf));
}

}  // namespace raycastd::engine
