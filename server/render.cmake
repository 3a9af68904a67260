# Render and trace routes, async jobs: sources added to raycastd_server / server_tests here.
target_sources(raycastd_server PRIVATE ${CMAKE_CURRENT_LIST_DIR}/routes_render.cpp)
