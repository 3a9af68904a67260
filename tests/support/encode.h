#pragma once
// Small encoders for building requests in tests: base64 (RFC 4648 §4) and OBJ text.

#include <sstream>
#include <string>

#include "engine/geometry/mesh.h"

namespace raycastd::testing {

inline std::string base64(const std::string& in) {
    static const char* kAlphabet =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (std::size_t i = 0; i < in.size(); i += 3) {
        const unsigned n = (static_cast<unsigned char>(in[i]) << 16) |
                           (i + 1 < in.size() ? static_cast<unsigned char>(in[i + 1]) << 8 : 0) |
                           (i + 2 < in.size() ? static_cast<unsigned char>(in[i + 2]) : 0);
        out += kAlphabet[(n >> 18) & 63];
        out += kAlphabet[(n >> 12) & 63];
        out += i + 1 < in.size() ? kAlphabet[(n >> 6) & 63] : '=';
        out += i + 2 < in.size() ? kAlphabet[n & 63] : '=';
    }
    return out;
}

/// The mesh as OBJ text with round-trip (17-digit) coordinates.
inline std::string to_obj(const engine::TriangleMesh& mesh) {
    std::ostringstream os;
    os.precision(17);
    for (const auto& p : mesh.positions)
        os << "v " << p.x << ' ' << p.y << ' ' << p.z << '\n';
    for (const auto& t : mesh.triangles) {
        os << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
    }
    return os.str();
}

}  // namespace raycastd::testing
