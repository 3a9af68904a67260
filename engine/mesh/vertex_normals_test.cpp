#include "engine/mesh/vertex_normals.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "engine/mesh/test_models.h"
#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

Vec3d corner_normal(const CornerNormals& n, std::size_t t, int k) {
    return Vec3d(n.normals[n.corners[t][k]]);
}

double angle_deg(const Vec3d& a, const Vec3d& b) {
    return std::acos(std::clamp(dot(normalize(a), normalize(b)), -1.0, 1.0)) * 180.0 / M_PI;
}

TEST(VertexNormals, IcosphereIsSmoothAndRadial) {
    // Every vertex of an icosphere is one smoothing group (neighbouring faces are ~10° apart at
    // level 2), and the area-weighted normal is within 2° of the radius through it (measured:
    // 1.35° at worst, where the subdivided icosahedron is least regular).
    const Object ico = testing::icosphere_object(2);
    const TriangleMesh& m = *ico.mesh;
    const CornerNormals n = compute_corner_normals(m);
    EXPECT_EQ(n.normals.size(), m.positions.size() + 1);  // + the zero normal at 0
    for (std::size_t t = 0; t < m.size(); ++t) {
        for (int k = 0; k < 3; ++k) {
            const Vec3d& p = m.positions[m.triangles[t][k]];
            EXPECT_LT(angle_deg(corner_normal(n, t, k), p), 2.0) << t << " " << k;
            EXPECT_NEAR(length(corner_normal(n, t, k)), 1.0, 1e-6);
        }
    }
}

// The same icosphere at 1e-300 and 1e300 (and between) has the same normals: its cross products
// underflowed or overflowed, every face counted as degenerate, and renders were flat.
TEST(VertexNormals, EveryScaleGivesTheSameNormals) {
    const CornerNormals unit = compute_corner_normals(*testing::icosphere_object(2).mesh);
    for (double s : {1e-300, 1e-160, 1e160, 1e300}) {
        const Object ico = testing::icosphere_object(2, {0, 0, 0}, s);
        const CornerNormals n = compute_corner_normals(*ico.mesh);
        ASSERT_EQ(n.normals.size(), unit.normals.size()) << s;
        for (std::size_t t = 0; t < ico.mesh->size(); ++t) {
            for (int k = 0; k < 3; ++k) {
                EXPECT_LT(angle_deg(corner_normal(n, t, k), corner_normal(unit, t, k)), 1e-4)
                    << s << " " << t << " " << k;
            }
        }
    }
}

TEST(VertexNormals, CubeKeepsItsCreases) {
    // Faces meet at 90° > 60°: each corner of the cube has three groups, one per side, and every
    // corner normal is its face's normal, for the indexed cube and for the STL-style soup (which
    // welding joins).
    const Object cube = testing::cube_object(0, 1);
    const TriangleMesh soup = testing::triangle_soup(*cube.mesh);
    for (const TriangleMesh* m : std::array<const TriangleMesh*, 2>{cube.mesh.get(), &soup}) {
        const CornerNormals n = compute_corner_normals(*m);
        EXPECT_EQ(n.normals.size(), 8u * 3u + 1u);
        for (std::size_t t = 0; t < m->size(); ++t) {
            const Vec3d face = triangle_normal(m->triangle(t));
            for (int k = 0; k < 3; ++k)
                EXPECT_LT(angle_deg(corner_normal(n, t, k), face), 1e-5) << t << " " << k;
        }
    }
}

TEST(VertexNormals, AreaWeighted) {
    // Two faces at a shared edge, 40° apart (within the crease angle), one with nine times the
    // other's area: the shared vertices' normal is their area-weighted mean, not the midway one.
    const double a = 40.0 * M_PI / 180.0;
    // Face 0 in the plane z = 0 (normal +z), area 9/2; face 1 hinged at the x axis, area 1/2.
    const Object o = testing::mesh_object(
        "hinge", {{0, 0, 0}, {1, 0, 0}, {0, 9, 0}, {0, -std::cos(a), std::sin(a)}},
        {{0, 1, 2}, {0, 3, 1}});
    const CornerNormals n = compute_corner_normals(*o.mesh);
    const Vec3d n0{0, 0, 1};
    const Vec3d n1 = triangle_normal(o.mesh->triangle(1));
    EXPECT_NEAR(angle_deg(n0, n1), 40.0, 1e-9);
    const Vec3d want = normalize(n0 * 9.0 + n1 * 1.0);
    EXPECT_LT(angle_deg(corner_normal(n, 0, 0), want), 1e-5);
    EXPECT_LT(angle_deg(corner_normal(n, 1, 0), want), 1e-5);
    // The corners that belong to one face only keep that face's normal.
    EXPECT_LT(angle_deg(corner_normal(n, 0, 2), n0), 1e-5);
    EXPECT_LT(angle_deg(corner_normal(n, 1, 1), n1), 1e-5);
}

TEST(VertexNormals, FlippedNeighbourAndDegenerateTriangle) {
    // A flat quad whose second triangle is listed clockwise: 180° from its neighbour, so its
    // corners get its own normal instead of cancelling the first's. A zero-area triangle's
    // corners point at the zero normal.
    const Object o = testing::mesh_object("quad", {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}},
                                          {{0, 1, 2}, {0, 3, 2}, {0, 1, 1}});
    const CornerNormals n = compute_corner_normals(*o.mesh);
    for (int k = 0; k < 3; ++k) {
        EXPECT_LT(angle_deg(corner_normal(n, 0, k), {0, 0, 1}), 1e-9);
        EXPECT_LT(angle_deg(corner_normal(n, 1, k), {0, 0, -1}), 1e-9);
        EXPECT_EQ(n.corners[2][k], 0u);
    }
    EXPECT_EQ(n.normals[0], Vec3f(0, 0, 0));
}

TEST(VertexNormals, LargeFanIsLinear) {
    // 100,000 triangles around one vertex (the case topology.h found quadratic in OpenMesh): a
    // shallow cone, every face within the crease angle of the first, so the apex is one group
    // with the axis as its normal. This finishes at once; a per-pair comparison would not.
    constexpr std::uint32_t kN = 100000;
    std::vector<Vec3d> p = {{0, 0, 0.1}};
    std::vector<std::array<std::uint32_t, 3>> t;
    for (std::uint32_t i = 0; i < kN; ++i) {
        const double phi = 2.0 * M_PI * i / kN;
        p.push_back({std::cos(phi), std::sin(phi), 0});
        t.push_back({0, 1 + i, 1 + (i + 1) % kN});
    }
    const Object o = testing::mesh_object("fan", std::move(p), std::move(t));
    const CornerNormals n = compute_corner_normals(*o.mesh);
    EXPECT_LT(angle_deg(corner_normal(n, 0, 0), {0, 0, 1}), 1e-6);
    EXPECT_EQ(n.corners[0][0], n.corners[kN - 1][0]);
}

TEST(VertexNormals, DuckAgreesWithItsFileNormals) {
    // The Duck's own NORMALs were made by its modelling tool; the computed ones over its welded
    // surface agree with them closely (UV seams weld together, so the seams are smooth too).
    // (testing::model_object merges parts and drops normals; the Duck is one part.)
    std::ifstream f(testing::models_dir() / "Duck/glTF-Binary/Duck.glb", std::ios::binary);
    if (!f)
        GTEST_SKIP() << "models not found at " << testing::models_dir();
    std::stringstream ss;
    ss << f.rdbuf();
    const auto duck = load_model(ss.str(), ModelFormat::glb, no_resources(), "Duck.glb");
    ASSERT_TRUE(duck.ok());
    ASSERT_EQ(duck->parts.size(), 1u);
    const TriangleMesh& m = duck->parts[0].mesh;
    ASSERT_EQ(m.normals.size(), m.positions.size());
    const CornerNormals n = compute_corner_normals(m);
    double sum = 0;
    std::size_t count = 0;
    for (std::size_t t = 0; t < m.size(); ++t) {
        for (int k = 0; k < 3; ++k) {
            if (n.corners[t][k] == 0)
                continue;
            sum += angle_deg(corner_normal(n, t, k), Vec3d(m.normals[m.triangles[t][k]]));
            ++count;
        }
    }
    ASSERT_GT(count, m.size() * 3 - 10);
    EXPECT_LT(sum / static_cast<double>(count), 4.0);  // measured: 2.6°
}

}  // namespace
}  // namespace raycastd::engine
