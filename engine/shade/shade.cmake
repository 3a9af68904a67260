# Shading: Phong terms, robust spawned rays, Whitted ray trees (included from engine/CMakeLists.txt).
target_sources(raycastd_engine PRIVATE
    ${CMAKE_CURRENT_LIST_DIR}/phong.cpp
    ${CMAKE_CURRENT_LIST_DIR}/spawn.cpp
    ${CMAKE_CURRENT_LIST_DIR}/whitted.cpp
)
if(BUILD_TESTING)
    target_sources(engine_tests PRIVATE
        ${CMAKE_CURRENT_LIST_DIR}/phong_test.cpp
        ${CMAKE_CURRENT_LIST_DIR}/spawn_test.cpp
        ${CMAKE_CURRENT_LIST_DIR}/whitted_test.cpp
    )
endif()
