# The preview page (GET /, GET /web/...): sources added to raycastd_server / server_tests here
# (included at the end of server/CMakeLists.txt). The page is read from disk at request time:
# from $RAYCASTD_WEB_ROOT when set, else from this source tree's clients/web.
target_sources(raycastd_server PRIVATE
    ${CMAKE_CURRENT_LIST_DIR}/routes_web.cpp
    ${CMAKE_CURRENT_LIST_DIR}/static_files.cpp
)
set_source_files_properties(${CMAKE_CURRENT_LIST_DIR}/routes_web.cpp PROPERTIES
    COMPILE_DEFINITIONS "RAYCASTD_WEB_ROOT_DEFAULT=\"${PROJECT_SOURCE_DIR}/clients/web\"")
if(BUILD_TESTING)
    target_sources(server_tests PRIVATE ${CMAKE_CURRENT_LIST_DIR}/static_files_test.cpp)
endif()
