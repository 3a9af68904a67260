#include "engine/points/batch.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "engine/math/bounds.h"

namespace raycastd::engine {

namespace {

/// x's low 6 bits spread to every third bit (bit b to bit 3b), by table: a loop over the bits
/// for each coordinate of a million points took most of spatial_order's time.
struct Spread {
    std::uint32_t bits[64] = {};
    constexpr Spread() {
        for (std::uint32_t x = 0; x < 64; ++x) {
            for (int b = 0; b < 6; ++b)
                bits[x] |= ((x >> b) & 1u) << (3 * b);
        }
    }
};
constexpr Spread kSpread;

/// The Morton code of cell (x, y, z), each below 64: their bits interleaved, x lowest
/// (Morton 1966).
std::uint32_t morton(std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    return kSpread.bits[x] | kSpread.bits[y] << 1 | kSpread.bits[z] << 2;
}

}  // namespace

std::vector<std::uint32_t> spatial_order(const Vec3d* points, std::size_t n) {
    if (n < kSpatialOrderMin || n > UINT32_MAX)
        return {};
    // The bounds and the codes over the threads (serial, the three passes took ~9% of a 1M-point
    // batch's wall time on A's shell); the counting sort's scatter stays serial.
    const Bounds3 box = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, n, 16384), Bounds3{},
        [&](const tbb::blocked_range<std::size_t>& r, Bounds3 b) {
            for (std::size_t i = r.begin(); i < r.end(); ++i) {
                // std::min and std::max, not Bounds3::extend's NaN-proof calls out of line: the
                // point is finite.
                const Vec3d& p = points[i];
                if (is_finite(p)) {
                    b.lo = {std::min(b.lo.x, p.x), std::min(b.lo.y, p.y), std::min(b.lo.z, p.z)};
                    b.hi = {std::max(b.hi.x, p.x), std::max(b.hi.y, p.y), std::max(b.hi.z, p.z)};
                }
            }
            return b;
        },
        [](Bounds3 a, const Bounds3& b) {
            a.extend(b);
            return a;
        });
    const Vec3d lo = box.lo, extent = box.diagonal();
    if (box.empty() || !is_finite(extent) || !(max_component(extent) > 0.0))
        return {};
    // About one point a cell at most (n^(1/3) cells an axis), and no more than 64 an axis: the
    // counts of 2^18 cells take 1 MB, and a cell of 1/64 of the bounds is already about a leaf of
    // the point tree on the meshes of bench_points. Points on a plane or a line fill fewer of the
    // cells (1M points on a plane: about 256 a cell), which still keeps them near each other.
    const int bits = std::clamp(static_cast<int>(std::ceil(std::log2(double(n)) / 3.0)), 1, 6);
    const double cells = double(1u << bits);
    // The cells an axis per unit length, a product per coordinate rather than a division; 0 (one
    // cell) for a flat axis, and for an extent so small (subnormal) that the quotient overflows:
    // inf times a zero offset would be NaN, whose conversion is undefined. The cell is clamped,
    // so rounding only moves a point to a neighbouring cell, which changes the order the points
    // are answered in, never an answer.
    auto per_length = [&](double e) {
        if (!(e > 0.0))
            return 0.0;
        const double k = cells / e;
        return k < std::numeric_limits<double>::infinity() ? k : 0.0;
    };
    const Vec3d scale(per_length(extent.x), per_length(extent.y), per_length(extent.z));
    auto cell = [&](double v, double l, double k) {
        return static_cast<std::uint32_t>(std::clamp((v - l) * k, 0.0, cells - 1.0));
    };
    std::vector<std::uint32_t> code(n);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 16384),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t i = r.begin(); i < r.end(); ++i) {
                              const Vec3d& p = points[i];
                              code[i] = is_finite(p) ? 1u + morton(cell(p.x, lo.x, scale.x),
                                                                   cell(p.y, lo.y, scale.y),
                                                                   cell(p.z, lo.z, scale.z))
                                                     : 0u;
                          }
                      });
    // A counting sort on the codes: linear and stable (points in one cell keep their order), and
    // no (code, index) pairs to build and sort.
    std::vector<std::uint32_t> start((std::size_t{1} << (3 * bits)) + 2, 0);
    for (std::uint32_t c : code)
        ++start[c + 1];
    for (std::size_t c = 1; c < start.size(); ++c)
        start[c] += start[c - 1];
    std::vector<std::uint32_t> order(n);
    for (std::size_t i = 0; i < n; ++i)
        order[start[code[i]]++] = static_cast<std::uint32_t>(i);
    return order;
}

}  // namespace raycastd::engine
