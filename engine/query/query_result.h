#pragma once
// The answers to a batch of rays, as QueryEngine::intersect writes them.

#include <cstdint>
#include <vector>

#include "engine/math/ray.h"
#include "engine/query_types.h"

namespace raycastd::engine {

/// The answers to a batch of rays.
///   closest: hits[i] is ray i's closest hit (!valid() on a miss);
///   any:     hits[i].valid() says whether ray i hits anything (nothing else is filled in);
///   all:     ray i's hits, sorted, are hits[offsets[i] .. offsets[i+1]);
///   count:   counts[i] is the number of hits of ray i (shared edges counted once).
struct QueryResult {
    Precision precision = Precision::exact;  ///< the path that answered
    std::vector<Hit> hits;
    std::vector<std::uint32_t> offsets;
    std::vector<std::uint32_t> counts;
};

}  // namespace raycastd::engine
