#include "server/model_source.h"

#include <map>
#include <string>
#include <vector>

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
    EXPECT_TRUE(queried.warnings.empty());  // nothing to say about a texture not asked for

    // Nor is its file read: the same model from the scene root, every read recorded (and,
    // below, a .gltf beside it).
    std::vector<std::string> asked;
    std::map<std::string, std::string> root = {{"m/x.obj", *decode_base64(kObj)},
                                               {"m/m.mtl", *decode_base64(kMtl)},
                                               {"m/t.png", *decode_base64(kPng)}};
    const FileSource files = [&](const std::string& p) -> engine::Result<std::string> {
        asked.push_back(p);
        auto it = root.find(p);
        if (it == root.end())
            return engine::Status::error(engine::Code::invalid_scene, "no file " + p);
        return it->second;
    };
    const Json by_uri = {{"objects", {{{"type", "mesh"}, {"uri", "m/x.obj"}}}}};
    EXPECT_TRUE(scene_from_document(by_uri, "", files, Limits{}).features().textures);
    EXPECT_EQ(asked, (std::vector<std::string>{"m/x.obj", "m/m.mtl", "m/t.png"}));
    asked.clear();
    EXPECT_FALSE(scene_from_document(by_uri, "", files, Limits{}, false).features().textures);
    EXPECT_EQ(asked, (std::vector<std::string>{"m/x.obj", "m/m.mtl"}));

    // The same for a .gltf whose image is a file: its buffer is read, its image is not, and its
    // texture coordinates are still read and checked (a TEXCOORD_0 of three components is
    // refused whether the scene is rendered or only queried).
    const float data[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 1};
    auto gltf = [&](int uv_components) {
        return std::string(
                   R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":60,"uri":"b.bin"}],)"
                   R"("bufferViews":[{"buffer":0,"byteLength":36},)"
                   R"({"buffer":0,"byteOffset":36,"byteLength":24}],)"
                   R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,)"
                   R"("type":"VEC3","min":[0,0,0],"max":[1,1,0]},{"bufferView":1,)"
                   R"("componentType":5126,"count":)") +
               (uv_components == 2 ? "3,\"type\":\"VEC2\"" : "2,\"type\":\"VEC3\"") +
               R"(}],"images":[{"uri":"t.png"}],"textures":[{"source":0}],"materials":)"
               R"([{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],"meshes":)"
               R"([{"primitives":[{"attributes":{"POSITION":0,"TEXCOORD_0":1},"material":0}]}],)"
               R"("nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0})";
    };
    root["g/x.gltf"] = gltf(2);
    root["g/b.bin"] = std::string(reinterpret_cast<const char*>(data), sizeof data);
    root["g/t.png"] = *decode_base64(kPng);
    const Json gdoc = {{"objects", {{{"type", "mesh"}, {"uri", "g/x.gltf"}}}}};
    asked.clear();
    EXPECT_TRUE(scene_from_document(gdoc, "", files, Limits{}).features().textures);
    EXPECT_EQ(asked, (std::vector<std::string>{"g/x.gltf", "g/b.bin", "g/t.png"}));
    asked.clear();
    EXPECT_FALSE(scene_from_document(gdoc, "", files, Limits{}, false).features().textures);
    EXPECT_EQ(asked, (std::vector<std::string>{"g/x.gltf", "g/b.bin"}));
    root["g/x.gltf"] = gltf(3);
    for (const bool textures : {true, false}) {
        EXPECT_THROW(scene_from_document(gdoc, "", files, Limits{}, textures), ApiError)
            << textures;
    }
}

}  // namespace
}  // namespace raycastd::server
