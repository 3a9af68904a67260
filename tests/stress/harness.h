#pragma once
// Measuring the engine against the quad-precision reference: one stress case (a scene and its
// rays) in, per-precision statistics out. Shared by the stress tests, the differential fuzzer
// and the accuracy report (bench/accuracy).

#include <memory>
#include <string>
#include <vector>

#include "engine/query/intersect.h"
#include "tests/stress/reference.h"

namespace raycastd::stress {

/// A scene and the rays that stress it. `closed[i]` marks closed meshes (leaks are counted
/// there).
struct StressCase {
    std::string suite;
    std::shared_ptr<engine::Scene> scene;
    std::vector<engine::Ray> rays;
    std::vector<bool> closed;
};

/// What one precision mode did on one case, judged against the reference.
struct ModeStats {
    std::string mode;  ///< fast / refined / exact
    std::string path;  ///< "embree" or "brute force" (the QueryEngine path that answered)
    std::size_t rays = 0;
    std::size_t near_ties = 0;          ///< the reference's own decision is inside the bands
    std::size_t near_tie_disagree = 0;  ///< of those, where the engine differs (not an error)
    std::size_t judged = 0;             ///< rays whose reference decisions are robust
    std::size_t wrong_hit = 0;          ///< hit where the reference misses, or the reverse
    std::size_t wrong_object = 0;       ///< hit the wrong object (or skipped a closer hit)
    std::size_t leaks = 0;              ///< passed through (or missed) a closed mesh
    std::size_t t_err_violations = 0;   ///< |t − t_ref| > the hit's own t_err
    std::vector<double> rel_err;        ///< |t − t_ref| / |t_ref| per judged hit
    std::vector<double> ulp_err;        ///< |t − t_ref| / ulp(t_ref) per judged hit
    double seconds = 0;                 ///< wall time of the engine's batch (after a warm-up)

    double max_rel() const;
    double median_rel() const;
    double max_ulps() const;
    double median_ulps() const;
    std::size_t wrong() const { return wrong_hit + wrong_object; }
    /// One line for the test log.
    std::string summary() const;
};

/// Runs the case's rays through a QueryEngine (mode closest) at each precision and judges every
/// answer. A scene of ≤ 16 primitives takes the brute-force path, whatever precision is asked:
/// then only one entry (exact) is returned. `repeats` > 1 times the batch several times and
/// keeps the fastest run.
std::vector<ModeStats> evaluate(const StressCase& c, int repeats = 1);

/// Adds `from`'s counts, errors and time to `into`.
void merge(ModeStats& into, const ModeStats& from);

/// One suite's totals for one precision mode and path.
struct SuiteStats {
    std::string suite;
    ModeStats stats;
};
/// Evaluates every case and adds up the cases of one suite (same name), in first-seen order.
std::vector<SuiteStats> evaluate_suites(const std::vector<StressCase>& cases, int repeats = 1);

/// The reference's answers for the case's rays (exact bands and float bands), computed once.
struct ReferenceAnswers {
    std::vector<RefAnswer> exact, coarse;
};
ReferenceAnswers reference_answers(const StressCase& c);

/// Judges one batch of engine answers against precomputed reference answers.
ModeStats judge(const StressCase& c, const std::vector<RefAnswer>& ref,
                const std::vector<engine::Hit>& hits, const std::string& mode,
                const std::string& path);

/// Adds far-away-enough dummy spheres (tiny, just outside the scene's bounds) until the scene
/// has more than 16 primitives, so that QueryEngine builds Embree's BVH for it.
void pad_for_embree(engine::Scene& scene, std::vector<bool>& closed);

/// Total primitives (triangles + spheres).
std::size_t primitive_count(const engine::Scene& scene);

}  // namespace raycastd::stress
