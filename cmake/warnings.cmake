# raycastd_warnings: linked PRIVATE by every target of ours (pbrt's pbrt_warnings pattern).
add_library(raycastd_warnings INTERFACE)
target_compile_options(raycastd_warnings INTERFACE
    -Wall -Wextra -Wpedantic -Wshadow -Werror)

# Stricter set for math and geometry, where silently mixing float and double is a real bug.
add_library(raycastd_strict_warnings INTERFACE)
target_compile_options(raycastd_strict_warnings INTERFACE -Wconversion -Wsign-conversion)
