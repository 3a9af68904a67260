#include "engine/utf8.h"

namespace raycastd::engine {

namespace {

/// The length of the well-formed sequence starting at s[i] (1–4), or 0 when it is not one;
/// then `bad` is the length of its maximal ill-formed subpart (at least 1). The ranges of the
/// second byte follow Unicode table 3-7.
std::size_t sequence(std::string_view s, std::size_t i, std::size_t& bad) {
    const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
    const unsigned char c = b(i);
    bad = 1;
    if (c < 0x80)
        return 1;
    std::size_t n = 0;
    unsigned char lo = 0x80, hi = 0xBF;
    if (c >= 0xC2 && c <= 0xDF) {
        n = 2;
    } else if (c >= 0xE0 && c <= 0xEF) {
        n = 3;
        if (c == 0xE0)
            lo = 0xA0;  // no overlong three-byte form
        if (c == 0xED)
            hi = 0x9F;  // no surrogates
    } else if (c >= 0xF0 && c <= 0xF4) {
        n = 4;
        if (c == 0xF0)
            lo = 0x90;  // no overlong four-byte form
        if (c == 0xF4)
            hi = 0x8F;  // nothing above U+10FFFF
    } else {
        return 0;  // a continuation byte, C0, C1 or F5–FF
    }
    for (std::size_t k = 1; k < n; ++k) {
        if (i + k >= s.size())
            return 0;
        const unsigned char x = b(i + k);
        if (x < (k == 1 ? lo : 0x80) || x > (k == 1 ? hi : 0xBF))
            return 0;
        bad = k + 1;
    }
    return n;
}

}  // namespace

std::string valid_utf8(std::string_view text) {
    std::string out;
    out.reserve(text.size());
    for (std::size_t i = 0; i < text.size();) {
        std::size_t bad = 1;
        const std::size_t n = sequence(text, i, bad);
        if (n) {
            out.append(text.substr(i, n));
            i += n;
        } else {
            out.append("\xEF\xBF\xBD");  // U+FFFD
            i += bad;
        }
    }
    return out;
}

}  // namespace raycastd::engine
