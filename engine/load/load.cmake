# Model loaders and the affine Transform they place geometry with. Included from
# engine/CMakeLists.txt after raycastd_engine and engine_tests exist.
target_sources(raycastd_engine PRIVATE
    ${CMAKE_CURRENT_LIST_DIR}/../math/transform.cpp
    ${CMAKE_CURRENT_LIST_DIR}/model_loader.cpp
    ${CMAKE_CURRENT_LIST_DIR}/gltf_loader.cpp
    ${CMAKE_CURRENT_LIST_DIR}/gltf_build.cpp
    ${CMAKE_CURRENT_LIST_DIR}/gltf_accessors.cpp
    ${CMAKE_CURRENT_LIST_DIR}/gltf_scene.cpp
    ${CMAKE_CURRENT_LIST_DIR}/obj_reader.cpp
    ${CMAKE_CURRENT_LIST_DIR}/ply_reader.cpp
    ${CMAKE_CURRENT_LIST_DIR}/stl_off_reader.cpp
)
# engine/math is held to -Wconversion (STYLE.md: mixing float and double there is a real bug).
set_source_files_properties(${CMAKE_CURRENT_LIST_DIR}/../math/transform.cpp
    PROPERTIES COMPILE_OPTIONS "-Wconversion;-Wsign-conversion")
# tinygltf parses glTF; OBJ, PLY, STL and OFF have their own small readers (see their headers
# for why OpenMesh's readers are not used), so OpenMesh is not linked.
# nlohmann/json (tinygltf's own JSON parser) is used only to explain a failed parse.
target_link_libraries(raycastd_engine PRIVATE TinyGLTF::TinyGLTF nlohmann_json::nlohmann_json)

if(BUILD_TESTING)
    target_sources(engine_tests PRIVATE
        ${CMAKE_CURRENT_LIST_DIR}/../math/transform_test.cpp
        ${CMAKE_CURRENT_LIST_DIR}/model_loader_test.cpp
        ${CMAKE_CURRENT_LIST_DIR}/model_invalid_test.cpp
        ${CMAKE_CURRENT_LIST_DIR}/gltf_loader_test.cpp
        ${CMAKE_CURRENT_LIST_DIR}/text_formats_test.cpp
    )
    # The glTF-Validator oracle reports are JSON; only the tests read them.
    target_link_libraries(engine_tests PRIVATE nlohmann_json::nlohmann_json)
endif()
