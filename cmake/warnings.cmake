# raycastd_warnings: linked PRIVATE by every target of ours (pbrt's pbrt_warnings pattern).
add_library(raycastd_warnings INTERFACE)
target_compile_options(raycastd_warnings INTERFACE
    -Wall -Wextra -Wpedantic -Wshadow -Werror)

# Stricter set for math and geometry, where silently mixing float and double is a real bug.
add_library(raycastd_strict_warnings INTERFACE)
target_compile_options(raycastd_strict_warnings INTERFACE -Wconversion -Wsign-conversion)

# Not a warning, but every target of ours links raycastd_warnings: no contraction of a·b + c into
# one fused multiply-add where the source did not write std::fma. The error bounds of the kernels
# (docs/numerics.md) count each product and sum rounded on its own, Woop's watertight edge
# functions must round the same on both triangles of an edge, and the scan's sphere rule must
# round the same in SSE2's and AVX's lanes. The default build targets x86-64 without FMA, where
# nothing changes; a build with -march=native or -mfma would otherwise contract (GCC contracts
# in C++ by default, clang within an expression).
target_compile_options(raycastd_warnings INTERFACE -ffp-contract=off)
