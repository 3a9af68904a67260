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

namespace raycastd::engine {

/// Whether this processor runs AVX, for code that picks its vector width at run time (the scan's
/// sphere culls, fast's packet lanes): GCC's and clang's runtime check, which also asks whether
/// the system saves AVX's registers (XGETBV). Asked once.
inline bool cpu_has_avx() {
    static const bool avx = __builtin_cpu_supports("avx");
    return avx;
}

}  // namespace raycastd::engine
