# The tests' own code is compiled for the speed of the build; the code under test keeps the
# build type's flags. Measured on the 2-core machine of stop 37 (clang, ASan+UBSan, Ninja, -j2):
# the test files were three quarters of the asan build's compile time (1,560 of 2,100
# CPU-seconds); an integration test file took 23 s at -O1 with the sanitizers, 12 s at -O0 with
# them and 8 s at -O0 without; gcc's -O3 took 1.5× its -O1 on the same files.
#
# raycastd_test_code: tests that run the engine in-process (engine_tests, stress_tests,
# bench_tests). -O1 in every build (the sanitizer presets' own level). Not -O0: their brute-force
# references would run several times slower, and so would the engine itself, since the linker
# keeps the test file's copy of an inline engine function when the test file comes first
# (PointBvh.AgreesWithBruteForceOnAnIcosphereRegionByRegion took 59 s under ASan at -O1 and
# 131 s at -O0).
add_library(raycastd_test_code INTERFACE)
target_compile_options(raycastd_test_code INTERFACE -O1)
# raycastd_server_test_code: server_tests (143 tests, 14 s under ASan at -O0). -O0 under the
# sanitizers, still instrumented; -O1 otherwise.
add_library(raycastd_server_test_code INTERFACE)
# raycastd_client_test_code: tests that only talk HTTP to the raycastd binary they start
# (integration_tests, golden_tests). The binary carries the sanitizers, the client does not
# need them: -O0 and uninstrumented under the sanitizer presets, -O1 otherwise.
# RAYCASTD_SERVER_SANITIZE tells the client how the server was built (e.g. that ASan's
# allocator keeps freed memory, so its resident size says nothing).
add_library(raycastd_client_test_code INTERFACE)
target_compile_definitions(raycastd_client_test_code INTERFACE
    RAYCASTD_SERVER_SANITIZE="${RAYCASTD_SANITIZE}")
if(RAYCASTD_SANITIZE)
    target_compile_options(raycastd_server_test_code INTERFACE -O0)
    target_compile_options(raycastd_client_test_code INTERFACE -O0 -fno-sanitize=all)
else()
    target_compile_options(raycastd_server_test_code INTERFACE -O1)
    target_compile_options(raycastd_client_test_code INTERFACE -O1)
endif()
# RAYCASTD_SANITIZED (0 or 1): a few brute-force references visit a quarter of their points
# under the sanitizers, where they cost ~11x release's time (engine/accel/point_bvh_test.cpp).
if(RAYCASTD_SANITIZE)
    target_compile_definitions(raycastd_test_code INTERFACE RAYCASTD_SANITIZED=1)
else()
    target_compile_definitions(raycastd_test_code INTERFACE RAYCASTD_SANITIZED=0)
endif()

# Precompiled headers: GoogleTest, nlohmann/json, cpp-httplib and the common standard headers
# took 2-5 s to parse in each of the ~80 test files that include them (one empty file including
# json, httplib and gtest: 4.2 s with gcc -O1, 5.5 s with clang's ASan+UBSan). Each test target
# builds its header once. The product's code is compiled as written in release, so a missing
# include still fails there; under the sanitizers raycastd_server precompiles too
# (server/CMakeLists.txt).
set(RAYCASTD_STD_PCH <algorithm> <array> <cmath> <cstdint> <functional> <limits> <map> <memory>
    <mutex> <optional> <string> <thread> <unordered_map> <utility> <vector>)
target_precompile_headers(raycastd_test_code INTERFACE <gtest/gtest.h> ${RAYCASTD_STD_PCH})
target_precompile_headers(raycastd_server_test_code INTERFACE <gtest/gtest.h>
    <nlohmann/json.hpp> <httplib.h> ${RAYCASTD_STD_PCH})
target_precompile_headers(raycastd_client_test_code INTERFACE <gtest/gtest.h>
    <nlohmann/json.hpp> <httplib.h> ${RAYCASTD_STD_PCH})
