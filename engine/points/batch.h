#pragma once
// How the point queries spread a batch over the worker threads: TBB blocks of 256 points (a
// closest-point query or a winding number costs microseconds, so fewer, larger tasks would leave
// threads idle at the end of a batch and smaller ones cost more to schedule than they hold),
// taken in a spatial order of the points (spatial_order) where the batch is large.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <tbb/parallel_for.h>

#include "engine/cancel.h"
#include "engine/math/vec3.h"

namespace raycastd::engine {

/// Below this many points a batch is taken in the order it came in.
constexpr std::size_t kSpatialOrderMin = 4096;

/// The indices of points[0..n) sorted by the Morton code (Z-order) of their cell in a grid of up
/// to 64³ cells over the points' bounds, so that points taken one after the other are near each
/// other and walk the same nodes of a scene's trees, which then stay in cache (on 1M points in a
/// shell about an 82k-triangle icosphere, whose point tree is 10 MB: docs/points.md). Points in
/// one cell keep their order; points that are not finite come first. Empty (the batch's own
/// order) for fewer than kSpatialOrderMin or more than 2³² − 1 points, and for bounds of no
/// extent or wider than a double holds. Memory: the 4 bytes a point returned, and as much again
/// and 1 MB while it is computed.
std::vector<std::uint32_t> spatial_order(const Vec3d* points, std::size_t n);

/// How far ahead in a block for_each_point's `ahead` is called.
constexpr std::size_t kPrefetchAhead = 8;

/// Calls f(i) for every i in [0, n), in parallel; each i at most once, in the order of `order`
/// (a permutation of [0, n), e.g. spatial_order's; empty: 0, 1, …) block by block.
/// `cancel` is asked once per block (engine/cancel.h); once it has fired, blocks not yet begun
/// are skipped (the caller asks cancel.fired()). With an order, ahead(j) is called before f(i)
/// for the j that comes kPrefetchAhead places after i in the block, to prefetch what f(j) will
/// read: in a spatial order the points are scattered through the caller's arrays, and the first
/// load of a closest-point query, its own point, missed the cache (6 % of a batch's time on
/// bench_points' shell).
template <class F, class A>
void for_each_point(std::size_t n, const CancelToken& cancel,
                    const std::vector<std::uint32_t>& order, F&& f, A&& ahead) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          if (cancel.cancelled())
                              return;
                          if (order.empty()) {
                              for (std::size_t k = r.begin(); k != r.end(); ++k)
                                  f(k);
                              return;
                          }
                          const std::size_t first = std::min(r.end(), r.begin() + kPrefetchAhead);
                          for (std::size_t k = r.begin(); k != first; ++k)
                              ahead(std::size_t{order[k]});
                          for (std::size_t k = r.begin(); k != r.end(); ++k) {
                              if (k + kPrefetchAhead < r.end())
                                  ahead(std::size_t{order[k + kPrefetchAhead]});
                              f(std::size_t{order[k]});
                          }
                      });
}

/// The same without prefetching.
template <class F>
void for_each_point(std::size_t n, const CancelToken& cancel,
                    const std::vector<std::uint32_t>& order, F&& f) {
    for_each_point(n, cancel, order, std::forward<F>(f), [](std::size_t) {});
}

/// The same in the order 0, 1, …, n − 1.
template <class F>
void for_each_point(std::size_t n, const CancelToken& cancel, F&& f) {
    for_each_point(n, cancel, {}, std::forward<F>(f));
}

}  // namespace raycastd::engine
