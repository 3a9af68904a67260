// Our OBJ/PLY/STL/OFF readers against OpenMesh's, on the published models in shared/data.
//
// raycastd does not load with OpenMesh (its readers open `mtllib` files behind the scene-root
// confinement, keep process-wide state, drop STL triangles with coincident corners, and can
// spin or allocate without bound on malformed PLY headers: see engine/load/loaders.h), but
// OpenMesh is a long-established, independent implementation of these formats, so it is the
// oracle here: wherever it reads a well-formed file, ours must find the same vertices (as a
// bounding box) and, up to the degenerate triangles OpenMesh drops, the same triangles.

#include <filesystem>
#include <fstream>
#include <sstream>

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <gtest/gtest.h>

#include "engine/load/model_loader.h"

namespace raycastd::engine {
namespace {

namespace fs = std::filesystem;
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<>;

const fs::path kModels = fs::path(RAYCASTD_SHARED_DIR) / "data" / "models";

std::string read_bytes(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

TEST(OpenMeshCrossCheck, SameGeometryAsOpenMesh) {
    if (!fs::exists(kModels))
        GTEST_SKIP() << "models not found at " << kModels;
    const char* files[] = {
        "stanford-bunny/stanford-bunny.obj",
        "spot/spot.obj",
        "suzanne/suzanne.obj",
        "cow/cow.obj",
        "fandisk/fandisk.obj",
        "Wuson/WusonOBJ.obj",
        "Wuson/Wuson.ply",
        "Wuson/Wuson.off",
        "bunny_ply/bunny.ply",
        "suzanne_ply/suzanne.ply",
        "teapot_stl/teapot.stl",
        "cube_off/Cube.off",
        "ballA_off/ballA.off",
        "featuretype/featuretype.STL",
        "spider/Spider_ascii.stl",
        "spider/Spider_binary.stl",
    };
    int compared = 0;
    for (const char* name : files) {
        const fs::path path = kModels / name;
        if (!fs::exists(path))
            continue;
        OmMesh om;
        OpenMesh::IO::Options opt;
        if (!OpenMesh::IO::read_mesh(om, path.string(), opt))
            continue;  // not OpenMesh's to judge
        const std::string bytes = read_bytes(path);
        auto format = format_from_name(path.filename().string());
        ASSERT_TRUE(format) << name;
        auto ours = load_model(bytes, *format, no_resources(), name);
        ASSERT_TRUE(ours.ok()) << name << ": " << ours.status().message;
        ASSERT_EQ(ours->parts.size(), 1u) << name;
        const TriangleMesh& mesh = ours->parts[0].mesh;

        // Same vertices: the bounding boxes agree to float precision (OpenMesh stores floats).
        Bounds3 om_bounds;
        for (auto vh : om.vertices()) {
            const auto& p = om.point(vh);
            om_bounds.extend(Vec3d{p[0], p[1], p[2]});
        }
        Bounds3 our_bounds;
        for (const auto& t : mesh.triangles) {
            for (auto i : t)
                our_bounds.extend(mesh.positions[i]);
        }
        const double tol = 1e-6 * (1.0 + length(om_bounds.diagonal()));
        for (std::size_t k = 0; k < 3; ++k) {
            EXPECT_NEAR(our_bounds.lo[k], om_bounds.lo[k], tol) << name;
            EXPECT_NEAR(our_bounds.hi[k], om_bounds.hi[k], tol) << name;
        }
        // Same triangles, except that OpenMesh drops degenerate and non-manifold faces that we
        // keep (so that triangle numbers match the file): ours ≥ OpenMesh's, and the excess is
        // small.
        const std::size_t om_tris = om.n_faces();
        EXPECT_GE(mesh.size(), om_tris) << name;
        EXPECT_LE(mesh.size() - om_tris, mesh.size() / 50 + 60) << name;
        ++compared;
    }
    EXPECT_GE(compared, 10);
}

}  // namespace
}  // namespace raycastd::engine
