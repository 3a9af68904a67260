#pragma once
// Picking instruction sets by processor.
//
// RAYCASTD_FMA_CLONES: compile a function twice, with and without hardware FMA, and pick one
// when the program loads (GCC's function multiversioning, an ifunc). ThreadSanitizer cannot
// run an ifunc resolver: the resolver is instrumented but runs during relocation, before the
// sanitizer's runtime exists, and the program dies before main (server_tests under
// -fsanitize=thread). Such builds define RAYCASTD_NO_TARGET_CLONES and get the default clone.

#if defined(RAYCASTD_NO_TARGET_CLONES)
#define RAYCASTD_FMA_CLONES
#else
#define RAYCASTD_FMA_CLONES __attribute__((target_clones("fma", "default")))
#endif

#include <cstdlib>
#include <cstring>

namespace raycastd::engine {

/// False where the environment says RAYCASTD_CPU=baseline: the code that picks its instruction
/// set at run time (cpu_has_avx, triangle_lanes_available) then takes its paths for a processor
/// without AVX, whatever this one has. Each of those paths gives the same answers, bit for bit,
/// so the switch is for the tests that check it (CTest EmbreeAccel.SuitesWithoutAvx, with
/// Embree's SSE kernels) and for a suspected vector bug in the field (docs/deploy.md). Read
/// once.
inline bool cpu_vectors_allowed() {
    static const bool allowed = [] {
        const char* v = std::getenv("RAYCASTD_CPU");
        return !(v && std::strcmp(v, "baseline") == 0);
    }();
    return allowed;
}

/// Whether this processor runs AVX, for code that picks its vector width at run time (the scan's
/// sphere culls, fast's packet lanes, the exact BVH's walk): GCC's and clang's runtime check,
/// which also asks whether the system saves AVX's registers (XGETBV). Asked once.
inline bool cpu_has_avx() {
    static const bool avx = cpu_vectors_allowed() && __builtin_cpu_supports("avx");
    return avx;
}

}  // namespace raycastd::engine
