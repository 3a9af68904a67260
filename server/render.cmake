# Render and trace routes, async jobs: sources added to raycastd_server / server_tests here
# (included at the end of server/CMakeLists.txt).
target_sources(raycastd_server PRIVATE
    ${CMAKE_CURRENT_LIST_DIR}/routes_render.cpp
    ${CMAKE_CURRENT_LIST_DIR}/job_queue.cpp
    ${CMAKE_CURRENT_LIST_DIR}/schema/render_doc.cpp
)
if(BUILD_TESTING)
    target_sources(server_tests PRIVATE
        ${CMAKE_CURRENT_LIST_DIR}/job_queue_test.cpp
        ${CMAKE_CURRENT_LIST_DIR}/schema/render_doc_test.cpp
    )
endif()
