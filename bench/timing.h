#pragma once
// Wall-clock timing for the benches: the median of a few repetitions after a warm-up, and a
// time-budgeted variant for paths that may be far slower than the ceiling (the engine's brute
// force path before Embree lands would need minutes for 1M rays against 1M triangles).

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <vector>

namespace raycastd::bench {

/// Seconds taken by one call of f.
template <class F>
double seconds(F&& f) {
    const auto start = std::chrono::steady_clock::now();
    f();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// One untimed warm-up call, then the median of `reps` timed calls.
template <class F>
double median_seconds(int reps, F&& f) {
    f();
    std::vector<double> t;
    for (int i = 0; i < reps; ++i)
        t.push_back(seconds(f));
    std::nth_element(t.begin(), t.begin() + reps / 2, t.end());
    return t[static_cast<std::size_t>(reps / 2)];
}

/// What a budgeted measurement timed: `rays` of the `total` (fewer when the full set would not
/// fit the budget; then they are an evenly strided sample).
struct BudgetedTiming {
    double seconds = 0.0;
    std::size_t rays = 0;
    std::size_t total = 0;
    bool sampled() const { return rays < total; }
    double mrays_per_s() const { return seconds > 0.0 ? rays / seconds * 1e-6 : 0.0; }
};

/// Samples smaller than this are timed twice and the faster run kept.
constexpr std::size_t kRetrySample = 16384;

/// Times run(n) — which traces a strided sample of n of the `total` rays and returns the
/// seconds its tracing took (preparing the sample is not timed) — starting with a small sample and
/// growing it until either the whole set is traced or a run takes a quarter of `budget_s`. A
/// full-set run that is quick is repeated and the median of three kept. The total time spent stays
/// within about 1.5 × budget_s.
template <class Run>
BudgetedTiming budgeted_seconds(std::size_t total, double budget_s, Run&& run) {
    std::size_t n = std::min<std::size_t>(total, 64);
    double t = 0.0;
    for (;;) {
        t = run(n);
        // A small sample is quick to repeat, and one descheduling of a thread on this shared
        // machine must not end the search at 64 rays.
        if (n < kRetrySample)
            t = std::min(t, run(n));
        if (n == total || t > 0.25 * budget_s)
            break;
        // Aim the next run at about half the budget, at least doubling.
        const double scale = std::max(2.0, 0.5 * budget_s / std::max(t, 1e-6));
        n = static_cast<std::size_t>(std::min<double>(static_cast<double>(total), n * scale));
    }
    if (n == total && 3.0 * t < budget_s) {
        std::vector<double> reps = {t, run(n), run(n)};
        std::sort(reps.begin(), reps.end());
        t = reps[1];
    }
    return {t, n, total};
}

/// The indices of an evenly strided sample of n out of total (all of them when n == total).
inline std::vector<std::size_t> strided_sample(std::size_t total, std::size_t n) {
    std::vector<std::size_t> idx(n);
    for (std::size_t i = 0; i < n; ++i)
        idx[i] = n == total ? i : i * total / n;
    return idx;
}

}  // namespace raycastd::bench
