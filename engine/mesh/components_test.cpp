#include "engine/mesh/components.h"

#include <gtest/gtest.h>

#include "engine/mesh/edge_map.h"
#include "engine/mesh/weld.h"
#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

/// The triangles of b appended to a (positions repeated, as a file of two parts lists them).
TriangleMesh joined(const TriangleMesh& a, const TriangleMesh& b) {
    TriangleMesh m = a;
    const auto base = static_cast<std::uint32_t>(m.positions.size());
    m.positions.insert(m.positions.end(), b.positions.begin(), b.positions.end());
    for (auto t : b.triangles)
        m.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    return m;
}

TEST(MeshComponents, OneComponentNeedsNoLabels) {
    const Object cube = testing::cube_object(0, 1);
    const MeshComponents c = find_components(*cube.mesh);
    ASSERT_EQ(c.bounds.size(), 1u);
    EXPECT_TRUE(c.of_triangle.empty());
    EXPECT_EQ(c.component(11), 0u);
    EXPECT_EQ(c.bounds[0].lo, (Vec3d{0, 0, 0}));
    EXPECT_EQ(c.bounds[0].hi, (Vec3d{1, 1, 1}));
}

TEST(MeshComponents, LabelsFollowTheFirstTriangleAndRepeatedPositionsWeld) {
    // Three cubes, the middle one as a soup (STL: every corner repeated), the third touching the
    // first at one corner only: two components, the soup welded into one.
    const TriangleMesh a = *testing::cube_object(0, 1).mesh;
    const TriangleMesh b = testing::triangle_soup(*testing::cube_object(3, 4).mesh);
    const TriangleMesh c = *testing::cube_object(1, 2).mesh;
    const MeshComponents k = find_components(joined(joined(a, b), c));
    ASSERT_EQ(k.bounds.size(), 2u);
    ASSERT_EQ(k.of_triangle.size(), 36u);
    for (std::size_t t = 0; t < 36; ++t)
        EXPECT_EQ(k.of_triangle[t], t >= 12 && t < 24 ? 1u : 0u) << t;
    EXPECT_EQ(k.bounds[0].lo, (Vec3d{0, 0, 0}));
    EXPECT_EQ(k.bounds[0].hi, (Vec3d{2, 2, 2}));
    EXPECT_EQ(k.bounds[1].lo, (Vec3d{3, 3, 3}));
    EXPECT_EQ(k.bounds[1].hi, (Vec3d{4, 4, 4}));
    // The count agrees with the topology's.
    EXPECT_EQ(count_components(weld(joined(joined(a, b), c))), 2u);
}

TEST(MeshComponents, NestedSurfacesAreTwoComponents) {
    // A hollow ball: the outer sphere and an inner one, apart, the inner box inside the outer's.
    const TriangleMesh outer = *testing::icosphere_object(2, {0, 0, 0}, 2.0).mesh;
    const TriangleMesh inner = *testing::icosphere_object(2, {0, 0, 0}, 1.0).mesh;
    const MeshComponents k = find_components(joined(outer, inner));
    ASSERT_EQ(k.bounds.size(), 2u);
    EXPECT_EQ(k.component(0), 0u);
    EXPECT_EQ(k.component(static_cast<std::uint32_t>(outer.size())), 1u);
    EXPECT_GT(k.bounds[0].hi.x, k.bounds[1].hi.x);
}

TEST(MeshComponents, AnEmptyMeshHasNone) {
    const MeshComponents k = find_components(TriangleMesh{});
    EXPECT_TRUE(k.bounds.empty());
    EXPECT_TRUE(k.of_triangle.empty());
}

}  // namespace
}  // namespace raycastd::engine
