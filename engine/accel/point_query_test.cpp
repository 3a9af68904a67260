// Closest points: Embree's point query (EmbreeAccel::closest_point) against brute force over
// every primitive, which must agree exactly (same winner, same bits), and the tie rule.

#include "engine/accel/point_query.h"

#include <random>

#include <gtest/gtest.h>

#include "engine/accel/embree_accel.h"
#include "engine/testing/expect_point_hit.h"
#include "engine/testing/point_meshes.h"

namespace raycastd::engine {
namespace {

std::unique_ptr<EmbreeAccel> bvh(const Scene& s) {
    auto a = EmbreeAccel::build(s);
    EXPECT_TRUE(a.ok());
    return a.ok() ? std::move(*a) : nullptr;
}

using testing::expect_same_point_hit;

TEST(PointQuery, EmbreeAgreesWithBruteForce) {
    for (double offset : {0.0, 1e5}) {
        const Scene s = testing::random_scene(5, offset);
        auto a = bvh(s);
        ASSERT_TRUE(a);
        std::mt19937_64 rng(6);
        std::uniform_real_distribution<double> pos(-9, 9);
        for (int i = 0; i < 5000; ++i) {
            const double scale = i % 10 == 0 ? 1e3 : 1.0;  // some far points
            const Vec3d p =
                Vec3d{pos(rng), pos(rng), pos(rng)} * scale + Vec3d{offset, offset, offset};
            const double reach = i % 3 == 0 ? 1.5 : kInfinity;
            SCOPED_TRACE(i);
            expect_same_point_hit(a->closest_point(p, reach), linear_closest_point(s, p, reach));
        }
    }
}

TEST(PointQuery, OnAClosedMeshEveryVertexAndEdgeMidpointIsOnTheSurface) {
    const Scene s = testing::scene_of({testing::icosphere_object(3, {0.3, -0.2, 0.1}, 2.0)});
    auto a = bvh(s);
    ASSERT_TRUE(a);
    const TriangleMesh& m = *s.objects[0].mesh;
    for (const auto& t : m.triangles) {
        for (const Vec3d& p : {m.positions[t[0]], (m.positions[t[0]] + m.positions[t[1]]) * 0.5,
                               (m.positions[t[0]] + m.positions[t[1]] + m.positions[t[2]]) / 3.0}) {
            auto h = a->closest_point(p, kInfinity);
            ASSERT_TRUE(h);
            EXPECT_LE(h->distance, h->err);
        }
    }
}

TEST(PointQuery, TiesGoToTheLowerObjectThenTheLowerPrimitive) {
    // Two triangles mirrored about z = 0 (objects 1 and 2), and a point on the mirror plane; the
    // cube (object 0) is far away. Then a shared edge inside one mesh.
    const Object far_cube = testing::cube_object(50, 51);
    Object upper = testing::mesh_object("up", {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}}, {{0, 1, 2}});
    Object lower = testing::mesh_object("down", {{0, 0, -1}, {1, 0, -1}, {0, 1, -1}}, {{0, 2, 1}});
    for (bool swap : {false, true}) {
        Scene s = testing::scene_of({far_cube, swap ? lower : upper, swap ? upper : lower});
        for (int k = 0; k < 3; ++k)  // more than 16 primitives: the BVH path too
            s.objects.push_back(testing::cube_object(60 + 3 * k, 61 + 3 * k));
        auto a = bvh(s);
        ASSERT_TRUE(a);
        for (const Vec3d& p : {Vec3d{0.25, 0.25, 0}, Vec3d{-1, -1, 0}, Vec3d{2, 0.1, 0}}) {
            auto h = a->closest_point(p, kInfinity);
            ASSERT_TRUE(h);
            EXPECT_EQ(h->object, 1u);
            expect_same_point_hit(h, linear_closest_point(s, p, kInfinity));
        }
    }
    // The cube's face z = 1 is triangles 2 and 3, sharing the diagonal (0,0,1)–(1,1,1)... in
    // cube_object's numbering {4,5,6}, {5,7,6}: the shared edge is 5–6, from (1,0,1) to (0,1,1).
    Scene s = testing::scene_of({testing::cube_object(0, 1)});
    for (int k = 0; k < 2; ++k)
        s.objects.push_back(testing::cube_object(10 + 3 * k, 11 + 3 * k));
    auto a = bvh(s);
    ASSERT_TRUE(a);
    for (double t : {0.1, 0.5, 0.77}) {
        const Vec3d on_edge = Vec3d{1, 0, 1} * (1 - t) + Vec3d{0, 1, 1} * t;
        const Vec3d p = on_edge + Vec3d{0, 0, 0.5};  // above the shared edge
        auto h = a->closest_point(p, kInfinity);
        ASSERT_TRUE(h);
        EXPECT_EQ(h->object, 0u);
        EXPECT_EQ(h->primitive, 2u);
        EXPECT_NEAR(h->distance, 0.5, 1e-15);
    }
}

TEST(PointQuery, MaxDistanceIsInclusiveAndSpheresAreExact) {
    Scene s = testing::scene_of({testing::sphere("s", {0, 0, 0}, 1.0, 0)});
    EXPECT_FALSE(linear_closest_point(s, {3, 0, 0}, 1.999));
    auto h = linear_closest_point(s, {3, 0, 0}, 2.0);
    ASSERT_TRUE(h);
    EXPECT_EQ(h->point, (Vec3d{1, 0, 0}));
    EXPECT_EQ(h->normal, (Vec3d{1, 0, 0}));
    EXPECT_EQ(h->distance, 2.0);
    for (int k = 0; k < 20; ++k)
        s.objects.push_back(testing::sphere("s", {10.0 + 3 * k, 0, 0}, 1.0, 0));
    auto a = bvh(s);
    ASSERT_TRUE(a);
    EXPECT_FALSE(a->closest_point({3, 0, 0}, 1.999));
    expect_same_point_hit(a->closest_point({3, 0, 0}, 2.0), h);
    expect_same_point_hit(a->closest_point({0.5, 0, 0}, kInfinity),
                          linear_closest_point(s, {0.5, 0, 0}, kInfinity));
}

TEST(PointQuery, DegenerateTrianglesAreNotPartOfTheSurface) {
    Scene s = testing::scene_of(
        {testing::mesh_object("sliver", {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}}, {{0, 1, 2}})});
    EXPECT_FALSE(linear_closest_point(s, {1, 1, 1}, kInfinity));
}

}  // namespace
}  // namespace raycastd::engine
