// Reference images with a tolerance (as Embree's tutorials are tested): scene documents from
// scenes/ rendered by the real binary and compared with images/*.png. The goldens were made by
// this renderer and looked at before they were committed; RAYCASTD_UPDATE_GOLDEN=1 rewrites
// them. A pixel differs when a channel is off by more than 8/255; a render passes when at most
// 0.5% of its pixels differ (sampling and float rounding move edge pixels, nothing else).

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <stb_image.h>

#include "tests/support/server_process.h"

namespace raycastd {
namespace {

using Json = nlohmann::json;
const std::string kGoldenDir = RAYCASTD_SOURCE_DIR "/tests/golden";
const std::string kModels = RAYCASTD_SHARED_DIR "/data/models";

std::string read_file(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

struct Pixels {
    int w = 0, h = 0;
    std::vector<unsigned char> rgb;
};

Pixels decode(const std::string& png) {
    Pixels p;
    int n = 0;
    unsigned char* data = stbi_load_from_memory(reinterpret_cast<const unsigned char*>(png.data()),
                                                static_cast<int>(png.size()), &p.w, &p.h, &n, 3);
    if (!data)
        return p;
    p.rgb.assign(data, data + static_cast<std::size_t>(p.w) * static_cast<std::size_t>(p.h) * 3);
    stbi_image_free(data);
    return p;
}

class Golden : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        server_ = new testing::ServerProcess({"--scene-root", RAYCASTD_SHARED_DIR "/data"});
    }
    static void TearDownTestSuite() {
        delete server_;
        server_ = nullptr;
    }

    /// Registers scenes/<scene>.json, renders it with `options`, compares with images/<name>.png.
    void check(const std::string& scene, const std::string& name, const Json& options) {
        check_body(read_file(kGoldenDir + "/scenes/" + scene + ".json"), "application/json", name,
                   options);
    }

    /// Registers `body` (a scene document or a model file), renders it with `options`, compares
    /// with images/<name>.png; the decoded render is left in last_.
    void check_body(const std::string& body, const std::string& content_type,
                    const std::string& name, const Json& options) {
        auto c = server_->client();
        auto reg = c->Post("/v1/scenes", body, content_type);
        ASSERT_TRUE(reg);
        ASSERT_LT(reg->status, 300) << reg->body;
        const std::string id = Json::parse(reg->body).at("id");
        auto res = c->Post("/v1/scenes/" + id + "/render", options.dump(), "application/json");
        ASSERT_TRUE(res);
        ASSERT_EQ(res->status, 200) << res->body;
        const std::string golden_path = kGoldenDir + "/images/" + name + ".png";
        if (std::getenv("RAYCASTD_UPDATE_GOLDEN")) {
            std::ofstream(golden_path, std::ios::binary) << res->body;
            GTEST_SKIP() << "wrote " << golden_path;
        }
        const Pixels got = decode(res->body);
        last_ = got;
        const Pixels want = decode(read_file(golden_path));
        ASSERT_FALSE(want.rgb.empty()) << "no golden image at " << golden_path;
        ASSERT_EQ(got.w, want.w);
        ASSERT_EQ(got.h, want.h);
        std::size_t differ = 0;
        for (std::size_t i = 0; i < got.rgb.size(); i += 3) {
            for (std::size_t k = 0; k < 3; ++k) {
                if (std::abs(int(got.rgb[i + k]) - int(want.rgb[i + k])) > 8) {
                    ++differ;
                    break;
                }
            }
        }
        const std::size_t pixels = got.rgb.size() / 3;
        EXPECT_LE(differ, pixels / 200) << differ << " of " << pixels << " pixels differ";
    }

    static testing::ServerProcess* server_;
    Pixels last_;
};
testing::ServerProcess* Golden::server_ = nullptr;

TEST_F(Golden, ThreeLitSpheres) {
    check("spheres", "spheres", Json{{"width", 160}, {"height", 120}, {"spp", 4}});
}

TEST_F(Golden, GlassSphere) {
    check("glass_sphere", "glass_sphere", Json{{"width", 160}, {"height", 120}, {"spp", 4}});
}

TEST_F(Golden, GlassAndMirrorSpheres) {
    check("tutorial_like", "tutorial_like",
          Json{{"width", 160}, {"height", 120}, {"spp", 4}, {"max_depth", 5}});
}

TEST_F(Golden, TutorialQuestion2SceneFromTheEye) {
    check("tutorial_q2", "tutorial_q2", Json{{"width", 120}, {"height", 90}, {"spp", 1}});
}

TEST_F(Golden, GltfDuck) {
    if (!std::filesystem::exists(kModels + "/Duck/glTF-Binary/Duck.glb")) {
        GTEST_SKIP() << "models not found at " << kModels;
    }
    check("duck", "duck", Json{{"width", 160}, {"height", 120}, {"spp", 4}});
}

TEST_F(Golden, BareDuckIsShadedAndYellow) {
    // The Duck as a new user posts it: the .glb alone, no lights, the render's defaults but the
    // size. Lighting auto gives it the headlight, so it is shaded by its normals, not a flat
    // silhouette, and its base-colour texture makes it yellow with an orange beak (issue 16).
    // Beyond the golden, statistical checks that hold whatever the golden: among the model's
    // pixels the brightness spreads (p90 − p10 of the luma, 8-bit, is over 60; a flat
    // silhouette gives ~0), there are many distinct colours, and red and green are well above
    // blue (a grey duck has them equal).
    const std::string glb = kModels + "/Duck/glTF-Binary/Duck.glb";
    if (!std::filesystem::exists(glb)) {
        GTEST_SKIP() << "models not found at " << kModels;
    }
    check_body(read_file(glb), "model/gltf-binary", "duck_bare",
               Json{{"width", 160}, {"height", 120}, {"spp", 4}});
    if (last_.rgb.empty())
        return;  // the golden was rewritten, or the check above failed already
    std::vector<double> luma;
    std::set<int> colours;
    double red = 0, green = 0, blue = 0;
    for (std::size_t i = 0; i < last_.rgb.size(); i += 3) {
        const int r = last_.rgb[i], g = last_.rgb[i + 1], b = last_.rgb[i + 2];
        if (r + g + b <= 12)
            continue;  // background (black)
        luma.push_back(0.2126 * r + 0.7152 * g + 0.0722 * b);
        colours.insert((r << 16) | (g << 8) | b);
        red += r, green += g, blue += b;
    }
    EXPECT_GT(red, 2.5 * blue);
    EXPECT_GT(green, 2 * blue);
    ASSERT_GT(luma.size(), last_.rgb.size() / 3 / 20) << "the duck covers under 5% of the image";
    std::sort(luma.begin(), luma.end());
    const double spread = luma[luma.size() * 9 / 10] - luma[luma.size() / 10];
    EXPECT_GT(spread, 60.0);
    EXPECT_GT(colours.size(), 100u);
}

TEST_F(Golden, BareObjWithoutNormalsIsSmoothWithCreases) {
    // fandisk.obj has no vn: its shading normals are computed (area-weighted over the weld,
    // split at creases), lit by the headlight, framed by the default camera. Its curved
    // patches shade smoothly, its sharp edges stay sharp.
    const std::string obj = kModels + "/fandisk/fandisk.obj";
    if (!std::filesystem::exists(obj)) {
        GTEST_SKIP() << "models not found at " << kModels;
    }
    check_body(read_file(obj), "model/obj", "fandisk_bare",
               Json{{"width", 160}, {"height", 120}, {"spp", 4}});
}

TEST_F(Golden, TexturedObj) {
    // spider.obj through its MTL's map_Kd JPEGs (Windows paths), the headlight and the default
    // camera, posted as a scene document so that its files resolve in the scene root.
    if (!std::filesystem::exists(kModels + "/spider/spider.obj")) {
        GTEST_SKIP() << "models not found at " << kModels;
    }
    check_body(R"({"objects":[{"type":"mesh","uri":"models/spider/spider.obj"}]})",
               "application/json", "spider_textured",
               Json{{"width", 160}, {"height", 120}, {"spp", 4}});
}

TEST_F(Golden, SkinnedFoxStands) {
    // Fox.gltf is skinned: posed by its 24 joints it stands, its bounds' height along +Y and
    // its feet at y ≈ 0 (unskinned, its mesh lies on its side). Seen side-on, textured.
    if (!std::filesystem::exists(kModels + "/Fox/glTF/Fox.gltf")) {
        GTEST_SKIP() << "models not found at " << kModels;
    }
    const std::string doc = R"({"objects":[{"type":"mesh","uri":"models/Fox/glTF/Fox.gltf"}]})";
    auto reg = server_->client()->Post("/v1/scenes", doc, "application/json");
    ASSERT_TRUE(reg);
    ASSERT_LT(reg->status, 300) << reg->body;
    const Json info = Json::parse(reg->body);
    const std::vector<double> lo = info.at("bounds").at("min"), hi = info.at("bounds").at("max");
    EXPECT_NEAR(lo[1], 0.0, 1.0);
    EXPECT_GT(hi[1] - lo[1], 2 * (hi[0] - lo[0]));
    EXPECT_TRUE(info.at("warnings").empty()) << info.at("warnings").dump();
    EXPECT_TRUE(info.at("features").at("textures").get<bool>());
    check_body(doc, "application/json", "fox_skinned",
               Json{{"width", 160},
                    {"height", 120},
                    {"spp", 4},
                    {"camera",
                     {{"position", {160, 60, 0}},
                      {"look_at", {0, 35, -10}},
                      {"up", {0, 1, 0}},
                      {"fov_y_deg", 45}}}});
}

TEST_F(Golden, GltfDuckNormals) {
    if (!std::filesystem::exists(kModels + "/Duck/glTF-Binary/Duck.glb")) {
        GTEST_SKIP() << "models not found at " << kModels;
    }
    check("duck", "duck_normals",
          Json{{"width", 120}, {"height", 90}, {"spp", 1}, {"shading", "normal"}});
}

}  // namespace
}  // namespace raycastd
