#pragma once
// The vocabulary of a ray query: modes, precisions, options and the shape of a batch's answers.

#include <cstdint>
#include <vector>

#include "engine/math/ray.h"

namespace raycastd::engine {

enum class Mode { closest, any, all, count };
enum class Precision { fast, refined, exact };

const char* to_string(Mode m);
const char* to_string(Precision p);

struct QueryOptions {
    Mode mode = Mode::closest;
    Precision precision = Precision::refined;
    bool want_normal = true;  ///< compute normal and front_face (skipped when not asked)
};

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
