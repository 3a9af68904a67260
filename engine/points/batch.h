#pragma once
// How the point queries spread a batch over the worker threads: TBB blocks of 256 points (a
// closest-point query or a winding number costs microseconds, so fewer, larger tasks would leave
// threads idle at the end of a batch and smaller ones cost more to schedule than they hold).

#include <cstddef>

#include <tbb/parallel_for.h>

#include "engine/cancel.h"

namespace raycastd::engine {

/// Calls f(i) for every i in [0, n), in parallel; each i at most once, in no particular order.
/// `cancel` is asked once per block (engine/cancel.h); once it has fired, blocks not yet begun
/// are skipped (the caller asks cancel.fired()).
template <class F>
void for_each_point(std::size_t n, const CancelToken& cancel, F&& f) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          if (cancel.cancelled())
                              return;
                          for (std::size_t i = r.begin(); i != r.end(); ++i)
                              f(i);
                      });
}

}  // namespace raycastd::engine
