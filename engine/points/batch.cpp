#include "engine/points/batch.h"

#include <algorithm>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "engine/math/bounds.h"

namespace raycastd::engine {

namespace {

/// The 3·bits-bit Morton code of cell (x, y, z): their bits interleaved, x lowest (Morton 1966).
std::uint32_t morton(std::uint32_t x, std::uint32_t y, std::uint32_t z, int bits) {
    std::uint32_t code = 0;
    for (int b = 0; b < bits; ++b) {
        code |= ((x >> b) & 1u) << (3 * b);
        code |= ((y >> b) & 1u) << (3 * b + 1);
        code |= ((z >> b) & 1u) << (3 * b + 2);
    }
    return code;
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
                if (is_finite(points[i]))
                    b.extend(points[i]);
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
    auto cell = [&](double v, double l, double e) {
        const double c = e > 0.0 ? std::floor((v - l) / e * cells) : 0.0;
        return static_cast<std::uint32_t>(std::clamp(c, 0.0, cells - 1.0));
    };
    std::vector<std::uint32_t> code(n);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 16384),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t i = r.begin(); i < r.end(); ++i) {
                              const Vec3d& p = points[i];
                              code[i] = is_finite(p) ? 1u + morton(cell(p.x, lo.x, extent.x),
                                                                   cell(p.y, lo.y, extent.y),
                                                                   cell(p.z, lo.z, extent.z), bits)
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
