# Model loaders and the affine Transform they place geometry with. Included from
# engine/CMakeLists.txt after raycastd_engine and engine_tests exist.
target_sources(raycastd_engine PRIVATE
    ${CMAKE_CURRENT_LIST_DIR}/../math/transform.cpp
)
# engine/math is held to -Wconversion (STYLE.md: mixing float and double there is a real bug).
set_source_files_properties(${CMAKE_CURRENT_LIST_DIR}/../math/transform.cpp
    PROPERTIES COMPILE_OPTIONS "-Wconversion;-Wsign-conversion")

if(BUILD_TESTING)
    target_sources(engine_tests PRIVATE
        ${CMAKE_CURRENT_LIST_DIR}/../math/transform_test.cpp
    )
endif()
