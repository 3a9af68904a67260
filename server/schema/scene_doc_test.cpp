#include "server/schema/scene_doc.h"

#include <limits>

#include <gtest/gtest.h>

namespace raycastd::server {
namespace {

ApiError parse_error(const std::string& text, const std::string& prefix = "") {
    try {
        parse_scene_doc(Json::parse(text), prefix, {});
    } catch (const ApiError& e) {
        return e;
    }
    ADD_FAILURE() << "no error for " << text;
    return ApiError(ErrorCode::internal, "");
}

TEST(SceneDoc, TutorialSceneWithDefaults) {
    engine::Scene s = parse_scene_doc(Json::parse(R"({"objects": [
        {"type": "sphere", "center": [0,0,10], "radius": 2},
        {"type": "sphere", "center": [0,3,8], "radius": 2, "material": "glass"},
        {"type": "triangle", "vertices": [[0,0,5],[1,0,5],[0,1,5]], "name": "abc"}],
      "materials": {"glass": {"transparency": 0.9, "ior": 1.5, "diffuse": [0.2,0.2,0.2]}},
      "lights": [{"type": "ambient", "intensity": [0.2,0.2,0.2]},
                 {"type": "point", "position": [5,5,0]},
                 {"type": "directional", "direction": [0,-1,0]}],
      "camera": {"position": [0,0,0], "look_at": [0,0,1], "up": [0,1,0], "fov_y_deg": 45}})"),
                                      "", {});
    ASSERT_EQ(s.objects.size(), 3u);
    EXPECT_EQ(s.objects[0].name, "sphere 1");
    EXPECT_EQ(s.objects[1].name, "sphere 2");
    EXPECT_EQ(s.objects[2].name, "abc");
    EXPECT_EQ(s.objects[0].material, 0u);
    EXPECT_EQ(s.material_names[s.objects[1].material], "glass");
    EXPECT_EQ(s.materials[s.objects[1].material].ior, 1.5);
    EXPECT_EQ(s.lights.size(), 3u);
    ASSERT_TRUE(s.camera);
    EXPECT_EQ(s.camera->fov_y_deg, 45.0);
    EXPECT_TRUE(s.features().shadows);
    EXPECT_TRUE(s.features().refraction);
    EXPECT_FALSE(s.features().reflection);
    EXPECT_TRUE(s.warnings.empty());
}

TEST(SceneDoc, ErrorsCarryJsonPointers) {
    ApiError e = parse_error(R"({"objects": [{"type":"sphere","center":[0,0,0],"radius":1},
        {"type":"sphere","center":[0,0,0],"radius":1},{"type":"sphere","center":[0,0,0],"radius":-1}]})",
                             "/scene");
    EXPECT_EQ(e.code, ErrorCode::invalid_scene);
    EXPECT_EQ(e.http_status(), 400);
    EXPECT_EQ(e.path, "/scene/objects/2/radius");
    EXPECT_STREQ(e.what(), "objects[2].radius must be > 0, got -1");

    EXPECT_EQ(parse_error(R"({"objects": [{"type":"cone"}]})").path, "/objects/0/type");
    EXPECT_EQ(parse_error(R"({"objects": [{"type":"sphere","radius":1}]})").path,
              "/objects/0/center");
    EXPECT_EQ(parse_error(R"({"objects": [{"type":"sphere","center":[0,0],"radius":1}]})").path,
              "/objects/0/center");
    EXPECT_EQ(parse_error(R"({"objects": [{"type":"sphere","center":[0,"x",0],"radius":1}]})").path,
              "/objects/0/center/1");
    EXPECT_EQ(
        parse_error(
            R"({"objects": [{"type":"sphere","center":[0,0,0],"radius":1,"material":"nope"}]})")
            .path,
        "/objects/0/material");
    EXPECT_EQ(parse_error(R"({"objects": []," lights": 1, "lights": [{"type":"spot"}]})").path,
              "/lights/0/type");
    EXPECT_EQ(parse_error(R"({"objects": [], "materials": {"a/b": {"ior": 0}}})").path,
              "/materials/a~1b/ior");
    EXPECT_EQ(parse_error(R"({"objects": {}})").path, "/objects");
    EXPECT_EQ(parse_error(R"([1,2])").code, ErrorCode::invalid_scene);
    EXPECT_EQ(
        parse_error(R"({"objects": [{"type":"triangle","vertices":[[0,0,0],[1,0,0]]}]})").path,
        "/objects/0/vertices");
    EXPECT_EQ(
        parse_error(R"({"objects": [], "camera": {"position":[0,0,0],"look_at":[0,0,0]}})").path,
        "/camera/look_at");
}

// nlohmann's parser refuses 1e400 itself (parse_json maps that to bad_json); a
// document built in code can still hold infinity, and that is refused here.
TEST(SceneDoc, InfiniteNumberIsBadJson) {
    Json doc = Json::parse(R"({"objects": [{"type":"sphere","center":[0,0,0],"radius":1}]})");
    doc["objects"][0]["center"][2] = std::numeric_limits<double>::infinity();
    try {
        parse_scene_doc(doc, "", {});
        ADD_FAILURE() << "infinity accepted";
    } catch (const ApiError& e) {
        EXPECT_EQ(e.code, ErrorCode::bad_json);
        EXPECT_EQ(e.path, "/objects/0/center/2");
    }
}

TEST(SceneDoc, UnknownKeysAreWarnings) {
    engine::Scene s = parse_scene_doc(
        Json::parse(R"({"objects": [{"type":"sphere","center":[0,0,0],"radius":1,"colour":"red"}],
                        "materials": {"m": {"difuse": [1,0,0]}}})"),
        "", {});
    ASSERT_EQ(s.warnings.size(), 2u);
    EXPECT_NE(s.warnings[0].find("/materials/m/difuse"), std::string::npos);
    EXPECT_NE(s.warnings[1].find("/objects/0/colour"), std::string::npos);
}

TEST(SceneDoc, MeshRejectedWithoutLoader) {
    EXPECT_EQ(parse_error(R"({"objects": [{"type":"mesh","uri":"x.obj"}]})").code,
              ErrorCode::invalid_scene);
}

}  // namespace
}  // namespace raycastd::server
