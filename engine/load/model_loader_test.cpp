// The loaders against the shared model corpus (shared/data/models, see its README.md): every
// valid model loads with the triangle count the README lists, the validator's negative glTF
// tests are rejected where their oracle reports say the geometry is unusable, and nothing in
// invalid/ crashes. Skipped when the corpus is absent.

#include "engine/load/model_loader.h"

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

namespace fs = std::filesystem;

fs::path models_dir() {
    return fs::path(RAYCASTD_SHARED_DIR) / "data" / "models";
}

#define REQUIRE_MODELS()                                                 \
    if (!fs::is_directory(models_dir())) {                               \
        GTEST_SKIP() << "models not found at " << models_dir().string(); \
    }

std::string read_bytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

/// A reader over one directory, as the server's scene-root reader would be (without its
/// confinement checks, which belong to the server's tests).
ResourceReader dir_reader(const fs::path& dir) {
    return [dir](const std::string& uri) -> Result<std::string> {
        fs::path p = dir / uri;
        if (!fs::is_regular_file(p))
            return Status::error(Code::not_found, uri + " not found");
        return read_bytes(p);
    };
}

Result<LoadedModel> load_file(const fs::path& p) {
    auto format = format_from_name(p.filename().string());
    if (!format)
        return Status::error(Code::unsupported_format, "no format for " + p.string());
    return load_model(read_bytes(p), *format, dir_reader(p.parent_path()), p.filename().string());
}

Result<LoadedModel> load_rel(const std::string& rel) {
    return load_file(models_dir() / rel);
}

// Triangle counts from models/README.md; for glTF the number of triangles over all mesh
// instances of the default scene (the README's bracketed number where it gives one).
const std::vector<std::pair<std::string, std::size_t>> kCorpus = {
    {"Triangle/glTF/Triangle.gltf", 1},
    {"TriangleWithoutIndices/glTF-Embedded/TriangleWithoutIndices.gltf", 1},
    {"SimpleMeshes/glTF-Embedded/SimpleMeshes.gltf", 2},
    {"MultipleScenes/glTF-Embedded/MultipleScenes.gltf", 2},
    {"Cameras/glTF/Cameras.gltf", 2},
    {"Cameras/glTF-Embedded/Cameras.gltf", 2},
    {"Box/glTF/Box.gltf", 12},
    {"Box/glTF-Binary/Box.glb", 12},
    {"BoxInterleaved/glTF-Binary/BoxInterleaved.glb", 12},
    {"BoxTextured/glTF/BoxTextured.gltf", 12},
    {"BoxTextured/glTF-Binary/BoxTextured.glb", 12},
    {"BoxTextured/glTF-Embedded/BoxTextured.gltf", 12},
    {"BoxVertexColors/glTF-Embedded/BoxVertexColors.gltf", 12},
    {"Cube/glTF/Cube.gltf", 12},
    {"Duck/glTF/Duck.gltf", 4212},
    {"Duck/glTF-Binary/Duck.glb", 4212},
    {"SimpleSparseAccessor/glTF/SimpleSparseAccessor.gltf", 12},
    {"AnimatedMorphCube/glTF/AnimatedMorphCube.gltf", 12},
    {"Fox/glTF/Fox.gltf", 576},
    {"SimpleSkin/glTF/simple_skin.gltf", 8},
    {"CesiumMilkTruck/glTF/CesiumMilkTruck.gltf", 3624},
    {"CesiumMilkTruck/glTF-Binary/CesiumMilkTruck.glb", 3624},
    {"2CylinderEngine/glTF-Binary/2CylinderEngine.glb", 121496},
    {"VertexColorTest/glTF/VertexColorTest.gltf", 36},
    {"MultiUVTest/glTF/MultiUVTest.gltf", 12},
    {"TwoSidedPlane/glTF/TwoSidedPlane.gltf", 2},
    {"sphere_lights/sphere_lights.gltf", 224},
    {"stanford-bunny/stanford-bunny.obj", 69451},
    {"spot/spot.obj", 5856},
    {"teapot/teapot.obj", 6320},
    {"suzanne/suzanne.obj", 968},
    {"cow/cow.obj", 5804},
    {"fandisk/fandisk.obj", 12946},
    {"beetle/beetle.obj", 2053},
    {"cornell_box/cornell_box.obj", 36},
    {"cornell_box/cornell_box_multimaterial.obj", 36},
    {"spider/spider.obj", 1368},
    {"spider/Spider_ascii.stl", 1368},
    {"spider/Spider_binary.stl", 1368},
    {"Wuson/WusonOBJ.obj", 3732},
    {"Wuson/Wuson.ply", 3732},
    {"Wuson/Wuson.stl", 3732},
    {"Wuson/Wuson.off", 3732},
    {"bunny_ply/bunny.ply", 16301},
    {"suzanne_ply/suzanne.ply", 968},
    {"teapot_stl/teapot.stl", 894},
    {"featuretype/featuretype.STL", 3476},
    {"featuretype/featuretype.ply", 3476},
    {"sphereWithHole/sphereWithHole.stl", 285},
    {"assimp_ply_cubes/cube.ply", 12},
    {"assimp_ply_cubes/cube_binary.ply", 12},
    {"assimp_ply_cubes/cube_uv.ply", 12},
    {"assimp_ply_cubes/float-color.ply", 1},
    {"cube_off/Cube.off", 12},
    {"ballA_off/ballA.off", 3796},
    {"openmesh_testfiles/cube1.off", 15048},
    {"openmesh_testfiles/cube1Binary.stl", 15048},
};

TEST(ModelCorpus, EveryValidModelLoadsWithTheReadmeTriangleCount) {
    REQUIRE_MODELS();
    for (const auto& [rel, triangles] : kCorpus) {
        SCOPED_TRACE(rel);
        auto model = load_rel(rel);
        ASSERT_TRUE(model.ok()) << model.status().message;
        EXPECT_EQ(model->triangle_count(), triangles);
        for (const ModelPart& part : model->parts) {
            for (const auto& t : part.mesh.triangles) {
                for (std::uint32_t v : t)
                    ASSERT_LT(v, part.mesh.positions.size());
            }
            ASSERT_TRUE(part.mesh.normals.empty() ||
                        part.mesh.normals.size() == part.mesh.positions.size());
            ASSERT_TRUE(part.mesh.triangle_material.empty() ||
                        part.mesh.triangle_material.size() == part.mesh.size());
            for (std::uint32_t m : part.mesh.triangle_material)
                ASSERT_LT(m, model->materials.size());
        }
        EXPECT_EQ(model->materials.size(), model->material_names.size());
    }
}

// The OpenMesh test files: 12 triangles each for the minimal cubes (quads and triangles).
TEST(ModelCorpus, OpenMeshTestFilesLoad) {
    REQUIRE_MODELS();
    for (const char* f : {"cube-minimal.obj", "cube-minimal.ply", "cube-minimal-normals.ply",
                          "cube-minimal-texCoords.obj", "cube-minimal-texCoords.ply",
                          "cube-minimal-vertexColors.ply", "meshlab.ply",
                          "cube-minimal-vertex-colors-after-vertex-definition.obj",
                          "cube-minimal-vertex-colors-as-vc-lines.obj"}) {
        SCOPED_TRACE(f);
        auto model = load_rel(std::string("openmesh_testfiles/") + f);
        ASSERT_TRUE(model.ok()) << model.status().message;
        EXPECT_EQ(model->triangle_count(), 12u);
    }
    auto square = load_rel("openmesh_testfiles/square_material.obj");
    ASSERT_TRUE(square.ok()) << square.status().message;
    ASSERT_FALSE(square->materials.empty());
}

// Box.gltf (draco's copy): node 0 carries the column-major matrix translating by (0, 0, 2)
// and node 1, its child, the mesh; the mesh's first POSITION is (−0.5, −0.5, 0.5) in Box0.bin,
// hence (−0.5, −0.5, 2.5) in the world.
TEST(ModelCorpus, NestedNodeTranslationPlacesBoxVertex) {
    REQUIRE_MODELS();
    auto model = load_rel("Box/glTF/Box.gltf");
    ASSERT_TRUE(model.ok()) << model.status().message;
    ASSERT_EQ(model->parts.size(), 1u);
    const TriangleMesh& mesh = model->parts[0].mesh;
    ASSERT_EQ(mesh.positions.size(), 24u);
    EXPECT_EQ(mesh.positions[0], Vec3d(-0.5, -0.5, 2.5));
    Bounds3 b = mesh.bounds();
    EXPECT_EQ(b.lo, Vec3d(-0.5, -0.5, 1.5));
    EXPECT_EQ(b.hi, Vec3d(0.5, 0.5, 2.5));
    ASSERT_EQ(mesh.normals.size(), 24u);
    // Box material "Red": baseColorFactor (0.8, 0, 0), metallic 0, roughness 1 (default).
    ASSERT_EQ(model->materials.size(), 1u);
    EXPECT_NEAR(model->materials[0].diffuse.x, 0.8, 1e-7);
    EXPECT_NEAR(model->materials[0].specular.x, 0.04, 1e-12);
    EXPECT_EQ(model->materials[0].shininess, 1.0);
    EXPECT_EQ(model->material_names[0], "Red");
}

// Box.glb (the Khronos Box): node 0's matrix has columns (1,0,0), (0,0,−1), (0,1,0), the
// Z-up → Y-up turn (x, y, z) ↦ (x, z, −y). The first POSITION (−0.5, −0.5, 0.5) lands at
// (−0.5, 0.5, 0.5); its normal (0, 0, 1) turns to (0, 1, 0).
TEST(ModelCorpus, NestedNodeRotationPlacesBoxVertexAndNormal) {
    REQUIRE_MODELS();
    auto model = load_rel("Box/glTF-Binary/Box.glb");
    ASSERT_TRUE(model.ok()) << model.status().message;
    ASSERT_EQ(model->parts.size(), 1u);
    const TriangleMesh& mesh = model->parts[0].mesh;
    EXPECT_EQ(mesh.positions[0], Vec3d(-0.5, 0.5, 0.5));
    ASSERT_EQ(mesh.normals.size(), 24u);
    EXPECT_NEAR(mesh.normals[0].x, 0.0f, 1e-6f);
    EXPECT_NEAR(mesh.normals[0].y, 1.0f, 1e-6f);
    EXPECT_NEAR(mesh.normals[0].z, 0.0f, 1e-6f);
}

TEST(ModelCorpus, GltfGlbAndEmbeddedVariantsGiveIdenticalGeometry) {
    REQUIRE_MODELS();
    auto a = load_rel("BoxTextured/glTF/BoxTextured.gltf");
    auto b = load_rel("BoxTextured/glTF-Binary/BoxTextured.glb");
    auto c = load_rel("BoxTextured/glTF-Embedded/BoxTextured.gltf");
    ASSERT_TRUE(a.ok() && b.ok() && c.ok());
    ASSERT_EQ(a->parts.size(), 1u);
    ASSERT_EQ(b->parts.size(), 1u);
    ASSERT_EQ(c->parts.size(), 1u);
    EXPECT_EQ(a->parts[0].mesh.positions, b->parts[0].mesh.positions);
    EXPECT_EQ(a->parts[0].mesh.positions, c->parts[0].mesh.positions);
    EXPECT_EQ(a->parts[0].mesh.triangles, b->parts[0].mesh.triangles);
    EXPECT_EQ(a->parts[0].mesh.triangles, c->parts[0].mesh.triangles);
}

// The same Wuson mesh in four encodings: same triangles, same bounds (up to the 6 decimals of
// the text formats against the float32 of binary STL).
TEST(ModelCorpus, WusonAgreesAcrossObjPlyStlOff) {
    REQUIRE_MODELS();
    std::vector<Bounds3> bounds;
    for (const char* rel :
         {"Wuson/WusonOBJ.obj", "Wuson/Wuson.ply", "Wuson/Wuson.stl", "Wuson/Wuson.off"}) {
        SCOPED_TRACE(rel);
        auto model = load_rel(rel);
        ASSERT_TRUE(model.ok()) << model.status().message;
        ASSERT_EQ(model->parts.size(), 1u);
        EXPECT_EQ(model->parts[0].name, fs::path(rel).filename().string());
        EXPECT_EQ(model->triangle_count(), 3732u);
        bounds.push_back(model->parts[0].mesh.bounds());
    }
    for (const Bounds3& b : bounds) {
        for (std::size_t i = 0; i < 3; ++i) {
            EXPECT_NEAR(b.lo[i], bounds[0].lo[i], 1e-5);
            EXPECT_NEAR(b.hi[i], bounds[0].hi[i], 1e-5);
        }
    }
}

// Duck's camera node (matrix with translation (400.113, 463.264, −431.078)) sits under a
// node scaled by 0.01, so the camera is at (4.00113, 4.63264, −4.31078) in the world; yfov
// 0.6605925559997559 rad = 37.8493°.
TEST(ModelCorpus, DuckCameraFromNodeHierarchy) {
    REQUIRE_MODELS();
    auto model = load_rel("Duck/glTF/Duck.gltf");
    ASSERT_TRUE(model.ok());
    ASSERT_TRUE(model->camera.has_value());
    EXPECT_NEAR(model->camera->position.x, 4.00113, 1e-5);
    EXPECT_NEAR(model->camera->position.y, 4.63264, 1e-5);
    EXPECT_NEAR(model->camera->position.z, -4.31078, 1e-5);
    EXPECT_NEAR(model->camera->fov_y_deg, 0.6605925559997559 * 180.0 / 3.14159265358979323846,
                1e-9);
    // The camera looks along its −Z: the third matrix column negated.
    const Vec3d forward = normalize(model->camera->look_at - model->camera->position);
    EXPECT_NEAR(forward.x, -0.5364750623703003, 1e-6);
    EXPECT_NEAR(forward.y, -0.6211478114128113, 1e-6);
    EXPECT_NEAR(forward.z, 0.571287989616394, 1e-6);
    // One unit ahead: the loader knows no scene to aim it at (the server does, once the
    // scene is assembled: engine/scene/camera.h aim_at).
    EXPECT_NEAR(length(model->camera->look_at - model->camera->position), 1.0, 1e-12);
}

// sphere_lights: a spot on node 1, and on its children a directional, another (empty) spot
// and, on a grandchild, a point light: four lights, the spots as points with warnings.
TEST(ModelCorpus, SphereLightsPunctual) {
    REQUIRE_MODELS();
    auto model = load_rel("sphere_lights/sphere_lights.gltf");
    ASSERT_TRUE(model.ok()) << model.status().message;
    ASSERT_EQ(model->lights.size(), 4u);
    int points = 0, directionals = 0;
    for (const Light& l : model->lights) {
        points += l.type == LightType::point;
        directionals += l.type == LightType::directional;
        EXPECT_LE(max_component(l.intensity), 1.0);
    }
    EXPECT_EQ(points, 3);
    EXPECT_EQ(directionals, 1);
    std::size_t spot_warnings = 0;
    for (const auto& w : model->warnings)
        spot_warnings += w.find("spot light") != std::string::npos;
    EXPECT_EQ(spot_warnings, 2u);
}

TEST(ModelCorpus, CornellBoxMaterialsFromMtl) {
    REQUIRE_MODELS();
    auto model = load_rel("cornell_box/cornell_box.obj");
    ASSERT_TRUE(model.ok());
    const TriangleMesh& mesh = model->parts[0].mesh;
    ASSERT_EQ(mesh.triangle_material.size(), mesh.size());
    std::set<std::string> names(model->material_names.begin(), model->material_names.end());
    EXPECT_TRUE(names.count("red"));
    EXPECT_TRUE(names.count("green"));
    for (std::size_t i = 0; i < model->materials.size(); ++i) {
        if (model->material_names[i] == "red") {
            EXPECT_EQ(model->materials[i].diffuse, Vec3d(1, 0, 0));
        }
    }
}

TEST(ModelCorpus, SniffingRecognisesCorpusFiles) {
    REQUIRE_MODELS();
    for (const auto& [rel, triangles] : kCorpus) {
        auto format = format_from_name(rel);
        ASSERT_TRUE(format);
        if (*format == ModelFormat::obj)
            continue;  // OBJ has no signature
        EXPECT_EQ(sniff_format(read_bytes(models_dir() / rel)), format) << rel;
    }
}

// The three BoxTextured variants keep the PNG beside the file, inside the GLB's BIN chunk and
// in a data: URI; each gives the same texture and the same texture coordinates.
TEST(ModelCorpus, BoxTexturedVariantsGiveOneTexture) {
    REQUIRE_MODELS();
    std::vector<LoadedModel> variants;
    for (const char* rel :
         {"BoxTextured/glTF/BoxTextured.gltf", "BoxTextured/glTF-Binary/BoxTextured.glb",
          "BoxTextured/glTF-Embedded/BoxTextured.gltf"}) {
        SCOPED_TRACE(rel);
        auto m = load_rel(rel);
        ASSERT_TRUE(m.ok()) << m.status().message;
        EXPECT_TRUE(m->warnings.empty()) << m->warnings[0];
        ASSERT_FALSE(m->materials.empty());
        ASSERT_TRUE(m->materials[0].texture);
        ASSERT_EQ(m->parts[0].mesh.corner_uvs.size(), m->parts[0].mesh.size());
        variants.push_back(std::move(*m));
    }
    for (std::size_t k = 1; k < variants.size(); ++k) {
        EXPECT_EQ(variants[k].materials[0].texture->image->rgb,
                  variants[0].materials[0].texture->image->rgb);
        EXPECT_EQ(variants[k].parts[0].mesh.corner_uvs, variants[0].parts[0].mesh.corner_uvs);
    }
}

// The Duck's texture is yellow: averaged over its texture coordinates, red and green are well
// above blue (in linear light).
TEST(ModelCorpus, DuckIsTexturedYellow) {
    REQUIRE_MODELS();
    auto m = load_rel("Duck/glTF-Binary/Duck.glb");
    ASSERT_TRUE(m.ok()) << m.status().message;
    const TriangleMesh& mesh = m->parts[0].mesh;
    ASSERT_EQ(mesh.corner_uvs.size(), mesh.size());
    const Material& mat = m->materials[mesh.triangle_material[0]];
    ASSERT_TRUE(mat.texture);
    Vec3d sum;
    for (const auto& corners : mesh.corner_uvs) {
        for (const auto& uv : corners)
            sum += mat.texture->sample(uv[0], uv[1]);
    }
    const Vec3d mean = sum / (3.0 * static_cast<double>(mesh.size()));
    EXPECT_GT(mean.x, 3 * mean.z);
    EXPECT_GT(mean.y, 2 * mean.z);
}

// The Fox is skinned (24 joints); posed by them it stands on its feet: its bounds are tallest
// along +Y from y ≈ 0, and longest along z, not lying on its side as its bind-pose mesh does.
TEST(ModelCorpus, SkinnedFoxStands) {
    REQUIRE_MODELS();
    auto m = load_rel("Fox/glTF/Fox.gltf");
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_TRUE(m->warnings.empty()) << m->warnings[0];
    Bounds3 b;
    for (const auto& part : m->parts)
        b.extend(part.mesh.bounds());
    const Vec3d size = b.diagonal();
    EXPECT_NEAR(b.lo.y, 0.0, 1.0);
    EXPECT_GT(size.y, 2 * size.x);
    EXPECT_GT(size.z, size.y);
    ASSERT_TRUE(m->materials[0].texture);
}

// spider.obj's MTL names its JPEG maps with Windows paths (".\wal67ar_small.jpg"); the four
// materials its faces use (of five in the MTL) are all textured.
TEST(ModelCorpus, SpiderObjIsTexturedThroughItsMtl) {
    REQUIRE_MODELS();
    auto m = load_rel("spider/spider.obj");
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_TRUE(m->warnings.empty()) << m->warnings[0];
    std::size_t textured = 0;
    for (const Material& mat : m->materials)
        textured += mat.texture ? 1 : 0;
    EXPECT_EQ(m->materials.size(), 4u);
    EXPECT_EQ(textured, 4u);
    EXPECT_EQ(m->parts[0].mesh.corner_uvs.size(), m->parts[0].mesh.size());
}

}  // namespace
}  // namespace raycastd::engine
