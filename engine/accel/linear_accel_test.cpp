#include "engine/accel/linear_accel.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

using testing::cube_object;
using testing::tutorial_spheres;

TEST(Linear, FarOriginsAreMovedToTheSceneAlongTheirLine) {
    // A triangle 1,024 across and a sphere below it, seen from 2^60 (1.2e18) away along the
    // exact line through (256, 256, 0) inside the triangle (every coordinate of the origin is a
    // double: 2^60 + 256 needs 52 bits). The brute-force paths move such a ray to the scene
    // (far_ray.h) and map its hits back; Stress.FarOrigins judges random lines of this kind
    // against the quad reference (5 of 301 decided wrongly at exact before the move).
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(
        testing::mesh_object("tri", {{0, 0, 0}, {1024, 0, 0}, {0, 1024, 0}}, {{0, 1, 2}}));
    s.objects.push_back(testing::sphere("ball", {156, 156, -100}, 10, 0));
    const SceneBall ball = scene_ball(s);
    ASSERT_TRUE(ball.usable);
    const Ray through{{0x1p60 + 256, 0x1p60 + 256, 0x1p60}, {-1, -1, -1}};
    ASSERT_TRUE(ball.far(through));
    const auto h = linear_closest_from_afar(s, ball, through, true);
    ASSERT_TRUE(h);
    EXPECT_EQ(h->object, 0u);
    EXPECT_LE(std::abs(h->t - 0x1p60), h->t_err + 256.0);  // t's ulp at 2^60 is 256
    EXPECT_TRUE(std::isfinite(h->t_err));
    EXPECT_TRUE(linear_any_from_afar(s, ball, through));
    // Every crossing: the triangle's mapped back from the moved ray, at 2^60; the sphere's on
    // the ray as given, at 2^60 + 100 ∓ 10/√3. All three round to 2^60 in double, and `closer`
    // orders them by object.
    std::vector<Hit> all;
    linear_all_from_afar(s, ball, through, false, all);
    ASSERT_EQ(all.size(), 3u);
    EXPECT_EQ(all[0].object, 0u);
    const double sphere_t[2] = {0x1p60 + 100 - 10 / std::sqrt(3.0),
                                0x1p60 + 100 + 10 / std::sqrt(3.0)};
    for (int k = 0; k < 2; ++k) {
        EXPECT_EQ(all[1 + k].object, 1u);
        EXPECT_LE(std::abs(all[1 + k].t - sphere_t[k]), all[1 + k].t_err + 256.0) << k;
    }
    // A line that passes 2,000 units beside the scene: the move finds it misses the ball.
    const Ray beside{{0x1p60 + 3000, 0x1p60 + 256, 0x1p60}, {-1, -1, -1}};
    EXPECT_FALSE(linear_closest_from_afar(s, ball, beside, true));
    EXPECT_FALSE(linear_any_from_afar(s, ball, beside));
    linear_all_from_afar(s, ball, beside, false, all);
    EXPECT_TRUE(all.empty());
    // A sphere is decided on the ray as given, not the moved one (a helper's reproducer: this
    // line passes 1e-11 outside a sphere at (1e6, 2e6, 3e6), and moved, its origin rounded by
    // u·3e6, it hit).
    Scene lone;
    lone.materials.push_back(Material{});
    lone.objects.push_back(testing::sphere("s", {1e6, 2e6, 3e6}, 0x1.9d5ea936814edp-4, 0));
    const Ray grazing{{-0x1.09da9a4f96456p+49, -0x1.acadc4615a6efp+49, 0x1.e6137553a5d48p+49},
                      {0x1.8f1990f321c69p-3, 0x1.41c429ebad4dfp-2, -0x1.6cd93f3c68594p-2}};
    const SceneBall lone_ball = scene_ball(lone);
    ASSERT_TRUE(lone_ball.far(grazing));
    EXPECT_FALSE(linear_closest(lone, grazing, false));
    EXPECT_FALSE(linear_closest_from_afar(lone, lone_ball, grazing, false));
    EXPECT_FALSE(linear_any_from_afar(lone, lone_ball, grazing));
    linear_all_from_afar(lone, lone_ball, grazing, false, all);
    EXPECT_TRUE(all.empty());
    // A sphere 36 units in front of the triangle along the same line: from 2^60 away both t
    // round to 2^60, and ordered by the client's t the tie went to the lower object, the
    // triangle behind it. Ordered by their places on the moved ray, the sphere comes first, as
    // for a near ray on the same line.
    Scene front = s;
    front.objects[1] = testing::sphere("ball", {286, 286, 30}, 10, 0);
    const auto first = linear_closest_from_afar(front, scene_ball(front), through, true);
    ASSERT_TRUE(first);
    EXPECT_EQ(first->object, 1u);
    EXPECT_TRUE(first->front_face);
    EXPECT_LE(std::abs(first->t - (0x1p60 - 30 - 10 / std::sqrt(3.0))), first->t_err + 256.0);
    const Ray on_the_line{{1256, 1256, 1000}, {-1, -1, -1}};
    EXPECT_EQ(linear_closest(front, on_the_line, false)->object, 1u);
    // A near ray is answered as it is.
    const Ray near{{256, 256, 10}, {0, 0, -1}};
    EXPECT_FALSE(ball.far(near));
    EXPECT_EQ(linear_closest_from_afar(s, ball, near, true)->t, 10.0);
}

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
