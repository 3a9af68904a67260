#include "engine/accel/linear_accel.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

using testing::cube_object;
using testing::tutorial_spheres;

// Tutorial Question 1: the first sphere hit is sphere 3 at (0, 0, 9 − √3).
TEST(Linear, TutorialFirstHitIsSphere3) {
    Scene s = tutorial_spheres();
    auto hit = linear_closest(s, Ray{{0, 0, 0}, {0, 0, 1}}, true);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->object, 2u);
    EXPECT_EQ(hit->primitive, 0u);
    EXPECT_EQ(hit->t, 7.267949192431123);
}

TEST(Linear, AllListsEveryRootSorted) {
    Scene s = tutorial_spheres();
    std::vector<Hit> hits;
    linear_all(s, Ray{{0, 0, 0}, {0, 0, 1}}, false, hits);
    ASSERT_EQ(hits.size(), 4u);
    EXPECT_EQ(hits[0].object, 2u);
    EXPECT_EQ(hits[1].object, 0u);
    EXPECT_EQ(hits[1].t, 8.0);
    EXPECT_EQ(hits[2].object, 2u);
    EXPECT_EQ(hits[3].t, 12.0);
}

TEST(Linear, ExactTieGoesToLowerObject) {
    Scene s = tutorial_spheres();
    s.objects.resize(1);
    Object twin = s.objects[0];
    twin.name = "twin";
    s.objects.push_back(twin);
    auto hit = linear_closest(s, Ray{{0, 0, 0}, {0, 0, 1}}, false);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->object, 0u);
}

TEST(Linear, AnyStopsAndAgrees) {
    Scene s = tutorial_spheres();
    EXPECT_TRUE(linear_any(s, Ray{{0, 0, 0}, {0, 0, 1}}));
    EXPECT_FALSE(linear_any(s, Ray{{0, 0, 0}, {0, 0, -1}}));
    Ray short_ray{{0, 0, 0}, {0, 0, 1}, 0, 7.0};
    EXPECT_FALSE(linear_any(s, short_ray));
}

// A ray through the cube's shared edges and vertices: two crossings, each listed once, and the
// closest hit on a shared edge names the lower-numbered triangle.
TEST(Linear, SharedEdgesCountOnce) {
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(cube_object(-1, 1));
    std::vector<Hit> hits;
    // Through the diagonal edge of the z = lo face (shared by triangles 0 and 1) and the
    // diagonal of the z = hi face.
    linear_all(s, Ray{{0, 0, -5}, {0, 0, 1}}, false, hits);
    ASSERT_EQ(hits.size(), 2u);
    EXPECT_EQ(hits[0].t, 4.0);
    EXPECT_EQ(hits[0].primitive, 0u);
    EXPECT_EQ(hits[1].t, 6.0);
    // Through two opposite corners: each corner is shared by several triangles.
    linear_all(s, Ray{{-2, -2, -2}, {1, 1, 1}}, false, hits);
    ASSERT_EQ(hits.size(), 2u);
    EXPECT_EQ(hits[0].t, 1.0);
    EXPECT_EQ(hits[1].t, 3.0);
    auto closest = linear_closest(s, Ray{{0, 0, -5}, {0, 0, 1}}, false);
    ASSERT_TRUE(closest);
    EXPECT_EQ(closest->primitive, 0u);
}

// Parity: any line through a closed mesh crosses it an even number of times, including lines
// aimed at its vertices and edges.
TEST(Linear, ClosedMeshParityOnEdgesAndVertices) {
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(cube_object(-1, 1));
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> coord(-4, 4);
    std::uniform_int_distribution<int> corner(0, 7);
    for (int i = 0; i < 2000; ++i) {
        const int c = corner(rng);
        const Vec3d target{(c & 1) ? 1.0 : -1.0, (c & 2) ? 1.0 : -1.0, (i % 3 == 0) ? 0.0 : -1.0};
        Vec3d origin{coord(rng), coord(rng), coord(rng)};
        if (std::abs(origin.x) <= 1 && std::abs(origin.y) <= 1 && std::abs(origin.z) <= 1) {
            origin.z = 6;
        }
        std::vector<Hit> hits;
        linear_all(s, Ray{origin, target - origin, -kInfinity, kInfinity}, false, hits);
        EXPECT_EQ(hits.size() % 2, 0u)
            << "origin " << origin.x << "," << origin.y << "," << origin.z;
    }
}

}  // namespace
}  // namespace raycastd::engine
