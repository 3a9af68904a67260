#pragma once
// The vocabulary of a ray query: modes, precisions and options. It sits beside status.h, below
// every folder of the engine, so that accel/ and query/ (and the server) share it without
// including one another; the answers of a batch are query/query_result.h.

#include "engine/cancel.h"

namespace raycastd::engine {

/// What a query asks of each ray: its closest hit, whether it hits anything, every hit, or how
/// many there are.
enum class Mode { closest, any, all, count };
/// Which path answers (`precision` in docs/api.md): Embree's float kernel, float traversal with the
/// hit recomputed in double, or every candidate decided in double.
enum class Precision { fast, refined, exact };

/// "closest", "any", "all", "count".
const char* to_string(Mode m);
/// "fast", "refined", "exact".
const char* to_string(Precision p);

/// What a batch of rays asks for.
struct QueryOptions {
    Mode mode = Mode::closest;
    Precision precision = Precision::refined;
    bool want_normal = true;  ///< compute normal and front_face (skipped when not asked)
    /// Checked once per block of QueryEngine::kBlockRays (never per ray): once it fires, blocks
    /// not yet begun are skipped and the batch answers Code::cancelled.
    CancelToken cancel{};
};

}  // namespace raycastd::engine
