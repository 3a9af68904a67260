# Rendering: camera rays, tiles, shading modes, image encoders (included from
# engine/CMakeLists.txt). PNG goes through Debian's libstb (stb_image_write).
target_sources(raycastd_engine PRIVATE
    ${CMAKE_CURRENT_LIST_DIR}/camera_rays.cpp
    ${CMAKE_CURRENT_LIST_DIR}/image.cpp
    ${CMAKE_CURRENT_LIST_DIR}/render.cpp
)
target_link_libraries(raycastd_engine PRIVATE PkgConfig::STB)
if(BUILD_TESTING)
    target_sources(engine_tests PRIVATE
        ${CMAKE_CURRENT_LIST_DIR}/image_test.cpp
        ${CMAKE_CURRENT_LIST_DIR}/render_test.cpp
    )
    # The tests decode the PNGs they make with stb_image.
    target_link_libraries(engine_tests PRIVATE PkgConfig::STB)
endif()
