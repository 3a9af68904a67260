#pragma once
// The query modes of the API over one prepared scene: closest, any, all and count, at the
// precision asked for. The scene and its acceleration structure are immutable once built and
// shared by every request thread.

#include <cstdint>
#include <memory>
#include <vector>

#include "engine/scene/scene.h"
#include "engine/status.h"

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

/// A scene made ready for queries.
class QueryEngine {
public:
    /// Validates the scene and builds what its size calls for. Never throws.
    static Result<std::shared_ptr<const QueryEngine>> build(std::shared_ptr<const Scene> scene);

    const Scene& scene() const { return *scene_; }
    const std::shared_ptr<const Scene>& scene_ptr() const { return scene_; }

    /// Answers every ray; rays must already be valid (finite, non-zero direction, tmin ≤ tmax).
    QueryResult intersect(const std::vector<Ray>& rays, const QueryOptions& options) const;

    /// The path a request asking for `asked` is answered by (tiny scenes always take exact).
    Precision effective_precision(Precision asked) const;

private:
    explicit QueryEngine(std::shared_ptr<const Scene> scene) : scene_(std::move(scene)) {}
    std::shared_ptr<const Scene> scene_;
};

/// Checks one ray against the API's rules; the message names the ray index.
Status validate_ray(const Ray& ray, std::size_t index);

}  // namespace raycastd::engine
