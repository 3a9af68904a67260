#include "server/model_source.h"

#include <gtest/gtest.h>

namespace raycastd::server {
namespace {

// A one-texel PNG (red), and an inline OBJ that textures its triangle with it.
const char* kPng =
    "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAIAAACQd1PeAAAADElEQVR4nGN4JicCAAMGARnZ3ys9AAAAAElFTkSuQmCC";
const char* kObj =  // "mtllib m.mtl", a triangle with texture coordinates, "usemtl t"
    "bXRsbGliIG0ubXRsCnYgMCAwIDAKdiAxIDAgMAp2IDAgMSAwCnZ0IDAgMAp2dCAxIDAKdnQgMCAxCnVzZW10bCB0"
    "CmYgMS8xIDIvMiAzLzMK";
const char* kMtl = "bmV3bXRsIHQKbWFwX0tkIHQucG5nCg==";  // "newmtl t", "map_Kd t.png"

FileSource no_files() {
    return [](const std::string& p) -> engine::Result<std::string> {
        return engine::Status::error(engine::Code::invalid_scene, "no file " + p);
    };
}

TEST(ModelSource, AQueriedSceneDecodesNoTexture) {
    // The stateless calls' scenes (textures false) are never rendered: the texture the same
    // document brings to a registered scene is not decoded for them.
    const Json doc = {{"objects",
                       {{{"type", "mesh"},
                         {"format", "obj"},
                         {"data_base64", kObj},
                         {"files", {{"m.mtl", kMtl}, {"t.png", kPng}}}}}}};
    const engine::Scene rendered = scene_from_document(doc, "", no_files(), Limits{});
    EXPECT_TRUE(rendered.features().textures);
    EXPECT_GT(rendered.texture_bytes(), 0u);
    const engine::Scene queried = scene_from_document(doc, "", no_files(), Limits{}, false);
    EXPECT_FALSE(queried.features().textures);
    EXPECT_EQ(queried.texture_bytes(), 0u);
    EXPECT_EQ(queried.triangle_count(), 1u);
}

}  // namespace
}  // namespace raycastd::server
