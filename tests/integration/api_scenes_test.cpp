// The scene registry over HTTP with the real binary: registration (documents and raw models),
// content addressing, confinement to the scene root, broken files, and restarts after kill -9.

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include "tests/support/encode.h"
#include "tests/support/server_process.h"

namespace raycastd {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

const fs::path kModels = fs::path(RAYCASTD_SHARED_DIR) / "data" / "models";

std::string read_file(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

#define REQUIRE_MODELS()                                                     \
    if (!fs::exists(kModels)) {                                              \
        GTEST_SKIP() << "models not found at " << kModels << " (../shared)"; \
    }

const char* kTutorial = R"({"objects":[{"type":"sphere","center":[0,0,10],"radius":2},
    {"type":"sphere","center":[0,3,8],"radius":2},{"type":"sphere","center":[0,1,9],"radius":2}]})";

struct Scenes : ::testing::Test {
    fs::path data = fs::temp_directory_path() /
                    ("raycastd_it_" + std::to_string(::getpid()) + "_" +
                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::unique_ptr<testing::ServerProcess> server;

    void SetUp() override {
        fs::remove_all(data);
        start();
    }
    void TearDown() override {
        server.reset();
        fs::remove_all(data);
    }
    void start() {
        const std::string root =
            fs::exists(kModels) ? kModels.string() : std::string(RAYCASTD_SOURCE_DIR);
        server = std::make_unique<testing::ServerProcess>(
            std::vector<std::string>{"--data-dir", data.string(), "--scene-root", root});
    }
    httplib::Result post(const std::string& path, const std::string& body,
                         const std::string& type = "application/json") {
        return server->client()->Post(path.c_str(), body, type.c_str());
    }
    Json post_ok(const std::string& path, const std::string& body, int status,
                 const std::string& type = "application/json") {
        auto res = post(path, body, type);
        EXPECT_TRUE(res);
        if (!res)
            return Json();
        EXPECT_EQ(res->status, status) << res->body;
        return Json::parse(res->body);
    }
    std::string error_code(const std::string& path, const std::string& body, int status,
                           const std::string& type = "application/json") {
        auto res = post(path, body, type);
        EXPECT_TRUE(res);
        if (!res)
            return "";
        EXPECT_EQ(res->status, status) << res->body;
        return Json::parse(res->body).at("error").at("code").get<std::string>();
    }
    Json closest(const std::string& id, const Json& ray) {
        return post_ok("/v1/scenes/" + id + "/intersect", Json{{"rays", {ray}}}.dump(), 200)
            .at("hits")
            .at(0);
    }
};

TEST_F(Scenes, RegisterTwiceSameIdThenQueryListDelete) {
    Json a = post_ok("/v1/scenes", kTutorial, 201);
    EXPECT_EQ(a.at("spheres"), 3);
    EXPECT_EQ(a.at("objects"), 3);
    EXPECT_EQ(a.at("features").at("shadows"), false);
    const std::string id = a.at("id");
    Json b = post_ok("/v1/scenes", kTutorial, 200);
    EXPECT_EQ(b.at("id"), id);

    Json hit = closest(id, {{"origin", {0, 0, 0}}, {"direction", {0, 0, 1}}});
    EXPECT_EQ(hit.at("name"), "sphere 3");
    EXPECT_EQ(hit.at("t").get<double>(), 7.267949192431123);

    auto list = server->client()->Get("/v1/scenes");
    ASSERT_TRUE(list);
    EXPECT_EQ(Json::parse(list->body).at("scenes").size(), 1u);
    auto one = server->client()->Get(("/v1/scenes/" + id).c_str());
    ASSERT_TRUE(one);
    EXPECT_EQ(Json::parse(one->body).at("id"), id);

    auto del = server->client()->Delete(("/v1/scenes/" + id).c_str());
    ASSERT_TRUE(del);
    EXPECT_EQ(del->status, 200);
    auto gone = server->client()->Get(("/v1/scenes/" + id).c_str());
    EXPECT_EQ(gone->status, 404);
    EXPECT_EQ(Json::parse(gone->body).at("error").at("code"), "scene_not_found");
    EXPECT_EQ(error_code("/v1/scenes/" + id + "/intersect", R"({"rays":[]})", 404),
              "scene_not_found");
}

TEST_F(Scenes, BadDocumentsLeaveTheRegistryAlone) {
    post_ok("/v1/scenes", kTutorial, 201);
    EXPECT_EQ(error_code("/v1/scenes",
                         R"({"objects":[{"type":"sphere","center":[0,0,0],"radius":-1}]})", 400),
              "invalid_scene");
    EXPECT_EQ(error_code("/v1/scenes", "{nope", 400), "bad_json");
    EXPECT_EQ(error_code("/v1/scenes", "hello", 400, "text/html"), "unsupported_format");
    auto list = server->client()->Get("/v1/scenes");
    EXPECT_EQ(Json::parse(list->body).at("scenes").size(), 1u);
}

TEST_F(Scenes, RestartAfterKill9AnswersTheSameHits) {
    REQUIRE_MODELS();
    const std::string tutorial = post_ok("/v1/scenes", kTutorial, 201).at("id");
    const Json duck_info = post_ok("/v1/scenes", read_file(kModels / "Duck/glTF-Binary/Duck.glb"),
                                   201, "model/gltf-binary");
    const std::string duck = duck_info.at("id");
    const std::string box =
        post_ok("/v1/scenes", R"({"objects":[{"type":"mesh","uri":"Box/glTF/Box.gltf"}]})", 201)
            .at("id");
    // Down the z axis through the centre of the duck's bounds.
    const Json& lo = duck_info.at("bounds").at("min");
    const Json& hi = duck_info.at("bounds").at("max");
    const double cx = 0.5 * (lo[0].get<double>() + hi[0].get<double>());
    const double cy = 0.5 * (lo[1].get<double>() + hi[1].get<double>());
    const Json ray = {{"origin", {cx, cy, hi[2].get<double>() + 100}}, {"direction", {0, 0, -1}}};
    const Json duck_hit = closest(duck, ray);
    ASSERT_EQ(duck_hit.at("hit"), true);
    const Json box_hit = closest(box, {{"origin", {0.1, 0.2, 5}}, {"direction", {0, 0, -1}}});
    ASSERT_EQ(box_hit.at("hit"), true);

    server->stop(SIGKILL);
    start();
    auto list = server->client()->Get("/v1/scenes");
    ASSERT_TRUE(list);
    EXPECT_EQ(Json::parse(list->body).at("scenes").size(), 3u);
    EXPECT_EQ(closest(duck, ray), duck_hit);
    EXPECT_EQ(closest(box, {{"origin", {0.1, 0.2, 5}}, {"direction", {0, 0, -1}}}), box_hit);
    EXPECT_EQ(closest(tutorial, {{"origin", {0, 0, 0}}, {"direction", {0, 0, 1}}}).at("name"),
              "sphere 3");
    // Posting again after the restart still finds the same scene.
    EXPECT_EQ(post_ok("/v1/scenes", kTutorial, 200).at("id"), tutorial);
}

TEST_F(Scenes, SummaryNamesTheCameraAndTheDefaultView) {
    // A client framing a scene as a render without a camera will (the preview page) reads both
    // from the summary: the scene's own camera, else the side its default camera stands on, −z
    // for spheres and triangles (the tutorial's eye looking along +z) and +z for a scene with a
    // model file, posted raw or as a document's mesh (its front faces +z, glTF 2.0 §3.4). Both
    // survive a restart.
    const char* with_camera = R"({"objects":[{"type":"sphere","center":[0,0,10],"radius":2}],
        "camera":{"position":[1,2,-3],"look_at":[0,0,10],"up":[0,1,0],"fov_y_deg":30}})";
    const Json doc = post_ok("/v1/scenes", with_camera, 201);
    EXPECT_EQ(doc.at("camera"), Json::parse(R"({"position":[1,2,-3],"look_at":[0,0,10],
                                                "up":[0,1,0],"fov_y_deg":30})"));
    EXPECT_EQ(doc.at("default_view"), "-z");
    const Json spheres = post_ok("/v1/scenes", kTutorial, 201);
    EXPECT_TRUE(spheres.at("camera").is_null());
    EXPECT_EQ(spheres.at("default_view"), "-z");
    const std::string off = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    const Json model = post_ok("/v1/scenes", off, 201, "model/off");
    EXPECT_TRUE(model.at("camera").is_null());
    EXPECT_EQ(model.at("default_view"), "+z");
    const Json doc_with_mesh = post_ok("/v1/scenes", R"({"objects":[
        {"type":"sphere","center":[0,0,10],"radius":2},{"type":"mesh","format":"off",
         "data_base64":"T0ZGCjMgMSAwCjAgMCAwCjEgMCAwCjAgMSAwCjMgMCAxIDIK"}]})",
                                       201);
    EXPECT_EQ(doc_with_mesh.at("default_view"), "+z");

    server->stop(SIGKILL);
    start();
    for (const Json* before : {&doc, &spheres, &model, &doc_with_mesh}) {
        const std::string id = before->at("id");
        auto got = server->client()->Get(("/v1/scenes/" + id).c_str());
        ASSERT_TRUE(got);
        const Json after = Json::parse(got->body);
        EXPECT_EQ(after.at("camera"), before->at("camera")) << id;
        EXPECT_EQ(after.at("default_view"), before->at("default_view")) << id;
    }
}

TEST_F(Scenes, AnInlineModelCarriesTheFilesItNames) {
    // An OBJ sent as data_base64 with its .mtl and texture in "files" (the only way a client
    // without the server's scene root can send them): the MTL in a folder beside it, its
    // map_Kd written with Windows separators, the texture's key too. The one-texel texture is
    // red, so the headlit triangle renders red.
    const std::string obj =
        "mtllib sub/tri.mtl\nv -1 -1 0\nv 1 -1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0.5 1\n"
        "usemtl red\nf 1/1 2/2 3/3\n";
    const std::string mtl = "newmtl red\nKd 1 1 1\nKs 0 0 0\nmap_Kd .\\tex\\red.png\n";
    const std::string png_b64 =
        "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAIAAACQd1PeAAAADElEQVR4nGN4JicCAAMGARnZ3ys9AAAAAElFTkSuQm"
        "CC";
    auto doc = [&](const Json& files) {
        Json mesh = {{"type", "mesh"}, {"format", "obj"}, {"data_base64", testing::base64(obj)}};
        if (!files.is_null())
            mesh["files"] = files;
        return Json{{"objects", {mesh}}}.dump();
    };
    const Json files = {{"sub/tri.mtl", testing::base64(mtl)}, {"sub\\tex\\red.png", png_b64}};
    const Json info = post_ok("/v1/scenes", doc(files), 201);
    EXPECT_TRUE(info.at("warnings").empty()) << info.at("warnings").dump();
    EXPECT_TRUE(info.at("features").at("textures").get<bool>());
    EXPECT_EQ(info.at("default_view"), "+z");
    const Json camera = {
        {"position", {0, 0, 3}}, {"look_at", {0, 0, 0}}, {"up", {0, 1, 0}}, {"fov_y_deg", 30}};
    auto img = server->client()->Post(
        ("/v1/scenes/" + info.at("id").get<std::string>() + "/render").c_str(),
        Json{{"width", 8}, {"height", 8}, {"format", "ppm"}, {"camera", camera}}.dump(),
        "application/json");
    ASSERT_TRUE(img);
    ASSERT_EQ(img->status, 200) << img->body;
    const std::string header = "P6\n8 8\n255\n";
    ASSERT_EQ(img->body.rfind(header, 0), 0u);
    const auto* centre =
        reinterpret_cast<const unsigned char*>(img->body.data()) + header.size() + 3 * (4 * 8 + 4);
    EXPECT_GT(centre[0], 3 * centre[1]) << int(centre[0]) << " " << int(centre[1]);
    EXPECT_GT(centre[0], 3 * centre[2]);

    // Without its files: the model loads, and the warning names what it could not read.
    const Json bare = post_ok("/v1/scenes", doc(Json()), 201);
    ASSERT_FALSE(bare.at("warnings").empty());
    EXPECT_NE(bare.at("warnings")[0].get<std::string>().find("sub/tri.mtl"), std::string::npos)
        << bare.at("warnings").dump();
    EXPECT_FALSE(bare.at("features").at("textures").get<bool>());

    // A .gltf's buffer the same way (positions at z = 4, in "buf/tri data.bin", named
    // percent-encoded): hit at t = 4 with it, 422 model_load_failed without it.
    const float z4[9] = {0, 0, 4, 1, 0, 4, 0, 1, 4};
    const std::string buffer(reinterpret_cast<const char*>(z4), sizeof z4);
    const std::string gltf =
        R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":36,"uri":"buf/tri%20data.bin"}],)"
        R"("bufferViews":[{"buffer":0,"byteLength":36}],"accessors":[{"bufferView":0,)"
        R"("componentType":5126,"count":3,"type":"VEC3","min":[0,0,4],"max":[1,1,4]}],)"
        R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],)"
        R"("scenes":[{"nodes":[0]}],"scene":0})";
    Json gmesh = {{"type", "mesh"}, {"format", "gltf"}, {"data_base64", testing::base64(gltf)}};
    EXPECT_EQ(error_code("/v1/scenes", Json{{"objects", {gmesh}}}.dump(), 422),
              "model_load_failed");
    gmesh["files"] = {{"buf/tri data.bin", testing::base64(buffer)}};
    const Json g = post_ok("/v1/scenes", Json{{"objects", {gmesh}}}.dump(), 201);
    const Json hit = closest(g.at("id"), {{"origin", {0.2, 0.2, 0}}, {"direction", {0, 0, 1}}});
    EXPECT_EQ(hit.at("t"), 4.0) << hit;

    // Refused, with the entry's pointer: a name out of the model's folder, an absolute one,
    // bytes that are not base64, files that are not an object, files beside a uri.
    for (const auto& [bad, where] :
         {std::pair{doc({{"../tri.mtl", "AA=="}}), "/objects/0/files/..~1tri.mtl"},
          std::pair{doc({{"/etc/passwd", "AA=="}}), "/objects/0/files/~1etc~1passwd"},
          std::pair{doc({{"sub/tri.mtl", "not base64!"}}), "/objects/0/files/sub~1tri.mtl"},
          std::pair{doc(Json::array()), "/objects/0/files"},
          std::pair{std::string(R"({"objects":[{"type":"mesh","uri":"Box/glTF/Box.gltf",)"
                                R"("files":{}}]})"),
                    "/objects/0/files"}}) {
        auto res = post("/v1/scenes", bad);
        ASSERT_TRUE(res);
        EXPECT_EQ(res->status, 400) << res->body;
        const Json e = Json::parse(res->body).at("error");
        EXPECT_EQ(e.at("code"), "invalid_scene") << res->body;
        EXPECT_EQ(e.at("path"), where) << res->body;
    }
}

TEST_F(Scenes, NamesInAnotherEncodingAreAnsweredAsUtf8) {
    // An OBJ written in Latin-1: the library and the material it names carry byte E9 ("é"),
    // which is not UTF-8, and the server's warnings quote them. Registered (and saved: the
    // fixture has a data dir), answered with U+FFFD in their place, and the same after a
    // restart; it had been 500 internal.
    const std::string obj =
        "mtllib caf\xE9.mtl\nusemtl caf\xE9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    const Json info = post_ok("/v1/scenes", obj, 201, "model/obj");
    ASSERT_EQ(info.at("warnings").size(), 2u) << info.at("warnings").dump();
    EXPECT_NE(info.at("warnings")[0].get<std::string>().find("'caf\xEF\xBF\xBD.mtl'"),
              std::string::npos)
        << info.at("warnings").dump();
    EXPECT_NE(info.at("warnings")[1].get<std::string>().find("'caf\xEF\xBF\xBD'"),
              std::string::npos)
        << info.at("warnings").dump();
    const std::string id = info.at("id");
    server->stop(SIGKILL);
    start();
    auto again = server->client()->Get(("/v1/scenes/" + id).c_str());
    ASSERT_TRUE(again);
    EXPECT_EQ(again->status, 200);
    EXPECT_EQ(Json::parse(again->body).at("warnings"), info.at("warnings"));
}

TEST_F(Scenes, TheTextureBudgetIsTheScenes) {
    // --max-texture-pixels 1: a scene's images may have 4 pixels together, however many mesh
    // objects bring them. Five objects, each an inline OBJ with its own one-texel PNG: four are
    // textured, the fifth is warned about. A stateless intersect on the same document answers
    // (its scene decodes no texture: server/model_source_test.cpp).
    testing::ServerProcess small({"--max-texture-pixels", "1"});
    const std::string png_b64 =
        "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAIAAACQd1PeAAAADElEQVR4nGN4JicCAAMGARnZ3ys9AAAAAElFTkSuQm"
        "CC";
    Json objects = Json::array();
    for (int k = 0; k < 5; ++k) {
        const std::string obj = "mtllib m.mtl\nv " + std::to_string(3 * k) +
                                " 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl t\n"
                                "f 1/1 2/2 3/3\n";
        objects.push_back(
            {{"type", "mesh"},
             {"format", "obj"},
             {"data_base64", testing::base64(obj)},
             {"files",
              {{"m.mtl", testing::base64("newmtl t\nmap_Kd t.png\n")}, {"t.png", png_b64}}}});
    }
    const Json doc = {{"objects", objects}};
    auto res = small.client()->Post("/v1/scenes", doc.dump(), "application/json");
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 201) << res->body;
    const Json info = Json::parse(res->body);
    EXPECT_TRUE(info.at("features").at("textures").get<bool>());
    ASSERT_EQ(info.at("warnings").size(), 1u) << info.at("warnings").dump();
    EXPECT_NE(info.at("warnings")[0].get<std::string>().find("/objects/4"), std::string::npos)
        << info.at("warnings")[0];
    EXPECT_NE(info.at("warnings")[0].get<std::string>().find("texture budget (0 pixels"),
              std::string::npos)
        << info.at("warnings")[0];
    auto stateless = small.client()->Post(
        "/v1/intersect",
        Json{{"scene", doc}, {"rays", {{{"origin", {0.2, 0.2, -1}}, {"direction", {0, 0, 1}}}}}}
            .dump(),
        "application/json");
    ASSERT_TRUE(stateless);
    EXPECT_EQ(stateless->status, 200) << stateless->body;
    EXPECT_EQ(Json::parse(stateless->body).at("hits").at(0).at("hit"), true);
}

TEST_F(Scenes, RawModelsAndCountsAndWarnings) {
    REQUIRE_MODELS();
    Json duck = post_ok("/v1/scenes", read_file(kModels / "Duck/glTF-Binary/Duck.glb"), 201,
                        "model/gltf-binary");
    EXPECT_EQ(duck.at("triangles"), 4212);
    // The Duck brings its own camera (a node at (400.113, 463.264, -431.078) under the root's
    // 0.01 scale, yfov 0.6606 rad): the summary tells it.
    const std::vector<double> eye = duck.at("camera").at("position");
    EXPECT_NEAR(eye[0], 4.00113, 1e-5);
    EXPECT_NEAR(eye[1], 4.63264, 1e-5);
    EXPECT_NEAR(eye[2], -4.31078, 1e-5);
    EXPECT_NEAR(duck.at("camera").at("fov_y_deg").get<double>(), 37.8492, 1e-4);
    // Its look_at, which glTF does not give, is where its axis passes closest to the centre of
    // the scene's bounds (the pivot the preview page orbits about), also when a document
    // turns and stretches it: aimed once the scene is placed.
    auto pivot_off_axis = [](const Json& info) {
        const std::vector<double> p = info.at("camera").at("position");
        const std::vector<double> l = info.at("camera").at("look_at");
        const std::vector<double> lo = info.at("bounds").at("min"),
                                  hi = info.at("bounds").at("max");
        double f[3], along = 0, norm = 0, offset = 0;
        for (int k = 0; k < 3; ++k)
            f[k] = l[k] - p[k], norm += f[k] * f[k];
        for (int k = 0; k < 3; ++k)
            along += (0.5 * (lo[k] + hi[k]) - l[k]) * f[k] / std::sqrt(norm);
        for (int k = 0; k < 3; ++k)
            offset += (l[k] - p[k]) * (l[k] - p[k]);
        return std::pair{along, std::sqrt(offset)};
    };
    EXPECT_NEAR(pivot_off_axis(duck).first, 0.0, 1e-9);
    EXPECT_GT(pivot_off_axis(duck).second, 5.0);
    const Json turned = post_ok("/v1/scenes",
                                R"({"objects":[{"type":"mesh","uri":"Duck/glTF-Binary/Duck.glb",
            "transform":{"rotate_deg":[0,90,0],"scale":[1,3,0.5]}}]})",
                                201);
    EXPECT_NEAR(pivot_off_axis(turned).first, 0.0, 1e-9);
    EXPECT_TRUE(turned.at("warnings").empty()) << turned.at("warnings").dump();
    // A typo inside the transform is said, as one anywhere else in the document is.
    const Json typo = post_ok("/v1/scenes",
                              R"({"objects":[{"type":"mesh","uri":"Duck/glTF-Binary/Duck.glb",
            "transform":{"rotate":[0,90,0],"matrix":[1]}}]})",
                              201);
    EXPECT_EQ(typo.at("warnings"), Json::array({"unknown key /objects/0/transform/matrix ignored",
                                                "unknown key /objects/0/transform/rotate ignored"}))
        << typo.at("warnings").dump();
    // A uri written with Windows separators names the same file (docs/api.md).
    const Json windows =
        post_ok("/v1/scenes",
                R"({"objects":[{"type":"mesh","uri":"Duck\\glTF-Binary\\.\\Duck.glb"}]})", 201);
    EXPECT_EQ(windows.at("triangles"), duck.at("triangles"));
    EXPECT_EQ(duck.at("default_view"), "+z");
    Json bunny = post_ok("/v1/scenes", read_file(kModels / "stanford-bunny/stanford-bunny.obj"),
                         201, "model/obj");
    EXPECT_EQ(bunny.at("triangles"), 69451);
    EXPECT_TRUE(bunny.at("camera").is_null());
    EXPECT_EQ(bunny.at("default_view"), "+z");
    Json stl =
        post_ok("/v1/scenes", read_file(kModels / "teapot_stl/teapot.stl"), 201, "application/sla");
    EXPECT_EQ(stl.at("triangles"), 894);
    // Without a content type the bytes tell.
    Json ply = post_ok("/v1/scenes", read_file(kModels / "Wuson/Wuson.ply"), 201,
                       "application/octet-stream");
    EXPECT_EQ(ply.at("triangles"), 3732);
}

// RFC 9110 §8.3.1: a media type's type and subtype are case-insensitive. The id hashes the
// type with the bytes, and 'Model/OBJ' had given the same triangle another scene.
TEST_F(Scenes, AMediaTypesCaseAndSpacesDoNotChangeTheId) {
    const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    const Json a = post_ok("/v1/scenes", obj, 201, "model/obj");
    for (const char* type : {"Model/OBJ", "MODEL/obj", " model/obj ; charset=utf-8"}) {
        const Json b = post_ok("/v1/scenes", obj, 200, type);
        EXPECT_EQ(b.at("id"), a.at("id")) << type;
    }
}

TEST_F(Scenes, SameGeometryInThreeGltfVariantsGivesIdenticalHits) {
    REQUIRE_MODELS();
    std::vector<std::string> ids;
    for (const char* uri :
         {"BoxTextured/glTF/BoxTextured.gltf", "BoxTextured/glTF-Binary/BoxTextured.glb",
          "BoxTextured/glTF-Embedded/BoxTextured.gltf"}) {
        Json doc = {{"objects", {{{"type", "mesh"}, {"uri", uri}, {"name", "box"}}}}};
        ids.push_back(post_ok("/v1/scenes", doc.dump(), 201).at("id"));
    }
    for (const Json& ray : {Json{{"origin", {0.1, 0.2, 5}}, {"direction", {0, 0, -1}}},
                            Json{{"origin", {3, 0.1, 0.05}}, {"direction", {-1, 0, 0}}},
                            Json{{"origin", {0.2, -4, 0.1}}, {"direction", {0, 1, 0.01}}}}) {
        const Json first = closest(ids[0], ray);
        EXPECT_EQ(first.at("hit"), true) << ray;
        EXPECT_EQ(closest(ids[1], ray), first);
        EXPECT_EQ(closest(ids[2], ray), first);
    }
}

TEST_F(Scenes, MeshTransformAndInlineData) {
    REQUIRE_MODELS();
    // Cube.off is the cube [-0.5, 0.5]³ (its file lists ±0.5); scaled by 2 and translated by
    // (10, 0, 0) it spans x in [9, 11]: a ray along −x from x = 20 meets it at t = 9.
    const std::string off = read_file(kModels / "cube_off/Cube.off");
    Json doc = {{"objects",
                 {{{"type", "mesh"},
                   {"format", "off"},
                   {"data_base64", ""},
                   {"transform", {{"translate", {10, 0, 0}}, {"scale", 2}}}}}}};
    const std::string b64 = testing::base64(off);
    doc["objects"][0]["data_base64"] = b64;
    Json s = post_ok("/v1/scenes", doc.dump(), 201);
    EXPECT_EQ(s.at("bounds").at("min"), Json::parse("[9, -1, -1]"));
    EXPECT_EQ(s.at("bounds").at("max"), Json::parse("[11, 1, 1]"));
    EXPECT_EQ(s.at("triangles"), 12);
    Json hit = closest(s.at("id"), {{"origin", {20, 0.1, 0.2}}, {"direction", {-1, 0, 0}}});
    ASSERT_EQ(hit.at("hit"), true);
    EXPECT_EQ(hit.at("t").get<double>(), 9.0);
    EXPECT_EQ(hit.at("normal"), Json::parse("[1, 0, 0]"));
    EXPECT_EQ(
        error_code("/v1/scenes", R"({"objects":[{"type":"mesh","data_base64":"AAAA"}]})", 400),
        "invalid_scene");
    EXPECT_EQ(error_code("/v1/scenes",
                         R"({"objects":[{"type":"mesh","format":"obj","data_base64":"@@"}]})", 400),
              "invalid_scene");
}

TEST_F(Scenes, PathTraversalIsRefused) {
    for (const char* uri : {"../API.md", "/etc/passwd", "Box/../../API.md",
                            "http://example.com/a.glb", "file:///etc/passwd"}) {
        Json doc = {{"objects", {{{"type", "mesh"}, {"uri", uri}}}}};
        auto res = post("/v1/scenes", doc.dump());
        ASSERT_TRUE(res);
        EXPECT_EQ(res->status, 400) << uri << " " << res->body;
        Json e = Json::parse(res->body).at("error");
        EXPECT_EQ(e.at("code"), "invalid_scene") << uri;
        EXPECT_EQ(e.at("path"), "/objects/0/uri") << uri;
    }
}

TEST_F(Scenes, SymlinkOutOfTheRootIsRefused) {
    const fs::path root = data.string() + "_root";
    fs::create_directories(root);
    std::ofstream(data.string() + "_secret.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    fs::create_symlink(data.string() + "_secret.obj", root / "link.obj");
    std::ofstream(root / "ok.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    server = std::make_unique<testing::ServerProcess>(
        std::vector<std::string>{"--scene-root", root.string()});
    EXPECT_EQ(error_code("/v1/scenes", R"({"objects":[{"type":"mesh","uri":"link.obj"}]})", 400),
              "invalid_scene");
    EXPECT_EQ(post_ok("/v1/scenes", R"({"objects":[{"type":"mesh","uri":"ok.obj"}]})", 201)
                  .at("triangles"),
              1);
    fs::remove_all(root);
    fs::remove(data.string() + "_secret.obj");
}

TEST_F(Scenes, BrokenModelsGet422AndNeverCrash) {
    REQUIRE_MODELS();
    int tried = 0;
    for (const auto& entry : fs::recursive_directory_iterator(kModels / "invalid")) {
        const std::string ext = entry.path().extension().string();
        std::string type;
        if (ext == ".glb")
            type = "model/gltf-binary";
        if (ext == ".obj")
            type = "model/obj";
        if (ext == ".stl")
            type = "application/sla";
        if (ext == ".ply")
            type = "application/x-ply";
        if (ext == ".off")
            type = "model/off";
        if (type.empty() || !entry.is_regular_file())
            continue;
        auto res = post("/v1/scenes", read_file(entry.path()), type);
        ASSERT_TRUE(res) << "server died on " << entry.path();
        EXPECT_TRUE(res->status == 201 || res->status == 200 ||
                    (res->status >= 400 && res->status < 500))
            << entry.path() << " " << res->status << " " << res->body;
        if (res->status >= 400) {
            Json e = Json::parse(res->body).at("error");
            EXPECT_FALSE(e.at("message").get<std::string>().empty());
        }
        ++tried;
    }
    EXPECT_GT(tried, 10);
    EXPECT_TRUE(server->alive());
    // A model whose extent passes the largest double parses but cannot be answered: 422, not
    // the scene document's 400. Vertices no triangle uses do not count.
    EXPECT_EQ(
        error_code("/v1/scenes", "v 1e308 0 0\nv -1e308 0 0\nv 0 1 0\nf 1 2 3\n", 422, "model/obj"),
        "model_load_failed");
    post_ok("/v1/scenes", "v 1e308 0 0\nv -1e308 0 0\nv 0 1 0\nv 1 0 0\nv 0 0 1\nf 3 4 5\n", 201,
            "model/obj");
    // A truncated GLB is a model that cannot be loaded: 422.
    std::string duck = read_file(kModels / "Duck/glTF-Binary/Duck.glb");
    EXPECT_EQ(error_code("/v1/scenes", duck.substr(0, duck.size() / 2), 422, "model/gltf-binary"),
              "model_load_failed");
}

}  // namespace
}  // namespace raycastd
