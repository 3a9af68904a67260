#include "engine/mesh/weld.h"

#include <cstring>

namespace raycastd::engine {

namespace {

constexpr std::uint32_t kNone = 0xFFFFFFFFu;

std::uint64_t bits(double v) {
    v += 0.0;  // −0 + 0 = +0 (IEEE 754 round to nearest): both zeros weld
    std::uint64_t b;
    std::memcpy(&b, &v, sizeof b);
    return b;
}

/// A 64-bit mix of the three coordinates' bits (the finaliser of MurmurHash3, per coordinate).
std::uint64_t hash(const Vec3d& p) {
    auto mix = [](std::uint64_t h) {
        h ^= h >> 33;
        h *= 0xff51afd7ed558ccdull;
        h ^= h >> 33;
        h *= 0xc4ceb9fe1a85ec53ull;
        h ^= h >> 33;
        return h;
    };
    return mix(bits(p.x) ^ mix(bits(p.y) ^ mix(bits(p.z))));
}

bool same(const Vec3d& a, const Vec3d& b) {
    return bits(a.x) == bits(b.x) && bits(a.y) == bits(b.y) && bits(a.z) == bits(b.z);
}

}  // namespace

WeldedTriangles weld(const TriangleMesh& mesh) {
    WeldedTriangles out;
    const std::size_t n_pos = mesh.positions.size();
    // Open addressing with linear probing, at most half full: one slot per position that a
    // triangle uses, holding the index of the first position seen at that point.
    std::size_t capacity = 16;
    while (capacity < 2 * std::min(n_pos, 3 * mesh.triangles.size()))
        capacity *= 2;
    const std::size_t mask = capacity - 1;
    std::vector<std::uint32_t> table(capacity, kNone);
    std::vector<std::uint32_t> id_of(n_pos, kNone);
    out.triangles.resize(mesh.triangles.size());
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        for (int k = 0; k < 3; ++k) {
            const std::uint32_t pi = mesh.triangles[t][k];
            if (id_of[pi] == kNone) {
                const Vec3d& p = mesh.positions[pi];
                std::size_t h = hash(p) & mask;
                while (table[h] != kNone && !same(mesh.positions[table[h]], p))
                    h = (h + 1) & mask;
                if (table[h] == kNone) {
                    table[h] = pi;
                    id_of[pi] = out.vertices++;
                } else {
                    id_of[pi] = id_of[table[h]];
                }
            }
            out.triangles[t][k] = id_of[pi];
        }
    }
    return out;
}

}  // namespace raycastd::engine
