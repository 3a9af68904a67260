#include "engine/mesh/weld.h"

#include <gtest/gtest.h>

#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

TEST(Weld, RepeatedPositionsShareOneVertex) {
    // The cube as STL stores it: three corners per triangle, 36 positions for 8 points.
    const Object cube = testing::cube_object(0, 1);
    const TriangleMesh soup = testing::triangle_soup(*cube.mesh);
    const WeldedTriangles w = weld(soup);
    EXPECT_EQ(w.vertices, 8u);
    ASSERT_EQ(w.triangles.size(), 12u);
    // Triangles keep their order and corners their positions.
    for (std::size_t t = 0; t < 12; ++t) {
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(w.triangles[t][k] == w.triangles[0][0],
                      soup.positions[soup.triangles[t][k]] == soup.positions[0]);
        }
    }
}

TEST(Weld, BothZerosWeldAndUnusedPositionsAreNotCounted) {
    TriangleMesh m;
    m.positions = {{0.0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-0.0, 0, -0.0}, {5, 5, 5}, {1, 0, 1e-300}};
    m.triangles = {{0, 1, 2}, {3, 2, 5}};
    const WeldedTriangles w = weld(m);
    EXPECT_EQ(w.vertices, 4u);  // (5,5,5) is unused; (1,0,1e-300) is not (1,0,0)
    EXPECT_EQ(w.triangles[1][0], w.triangles[0][0]);
    EXPECT_EQ(w.triangles[1][1], w.triangles[0][2]);
    EXPECT_EQ(w.triangles[1][2], 3u);
}

}  // namespace
}  // namespace raycastd::engine
