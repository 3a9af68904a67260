// Inside/outside object by object: parity rays through edges and along face planes (a
// non-convex voxel solid, where a ray from a point in a face's plane slides along that face),
// several objects at once, and the sphere and on-surface rules.

#include "engine/points/inside.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "engine/points/point_queries.h"
#include "engine/testing/point_meshes.h"

namespace raycastd::engine {
namespace {

std::shared_ptr<const QueryEngine> prepare(Scene s) {
    auto e = QueryEngine::build(std::make_shared<Scene>(std::move(s)));
    EXPECT_TRUE(e.ok());
    return e.ok() ? *e : nullptr;
}

std::vector<Occupancy> classify(const QueryEngine& e, const std::vector<Vec3d>& pts,
                                bool all_objects = true) {
    std::vector<PointHit> nearest(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) {
        auto h = e.closest_point(pts[i], kInfinity);
        if (h)
            nearest[i] = *h;
    }
    std::vector<Occupancy> out(pts.size());
    EXPECT_TRUE(
        classify_points(e, pts.data(), nearest.data(), pts.size(), all_objects, {}, out.data())
            .ok());
    return out;
}

const std::vector<std::array<int, 3>> kStairs = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0},
                                                 {1, 1, 0}, {0, 2, 0}, {0, 0, 1}};

bool in_stairs(const Vec3d& p) {
    for (const auto& c : kStairs) {
        if (p.x > c[0] && p.x < c[0] + 1 && p.y > c[1] && p.y < c[1] + 1 && p.z > c[2] &&
            p.z < c[2] + 1)
            return true;
    }
    return false;
}

/// In the closed solid (inside or on its surface): some point of a tiny cube around p is inside.
bool in_closed_stairs(const Vec3d& p) {
    for (double dx : {-1e-6, 1e-6})
        for (double dy : {-1e-6, 1e-6})
            for (double dz : {-1e-6, 1e-6})
                if (in_stairs(p + Vec3d{dx, dy, dz}))
                    return true;
    return false;
}

/// On its surface: in the closed solid, but some point of a tiny cube around p is outside.
bool on_stairs_boundary(const Vec3d& p) {
    if (!in_closed_stairs(p))
        return false;
    for (double dx : {-1e-6, 1e-6})
        for (double dy : {-1e-6, 1e-6})
            for (double dz : {-1e-6, 1e-6})
                if (!in_stairs(p + Vec3d{dx, dy, dz}))
                    return true;
    return false;
}

TEST(Inside, NonConvexSolidOnGridPlanes) {
    // Points on the half-integer and integer planes of a staircase of voxels: parity rays from
    // them run through edges, vertices and along face planes.
    const Object o = testing::voxel_object(kStairs);
    Scene s = testing::scene_of({o});
    auto e = prepare(std::move(s));
    ASSERT_EQ(e->topology()[0].sign, SignMethod::parity);
    ASSERT_TRUE(e->topology()[0].closed);
    std::vector<Vec3d> pts;
    for (int x = -1; x <= 7; ++x)
        for (int y = -1; y <= 7; ++y)
            for (int z = -1; z <= 5; ++z)
                pts.push_back(Vec3d{x * 0.5, y * 0.5, z * 0.5});
    const auto occ = classify(*e, pts);
    int inside = 0, boundary = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
        const bool b = on_stairs_boundary(pts[i]);
        const bool truth = in_closed_stairs(pts[i]);
        EXPECT_EQ(occ[i].inside, truth) << pts[i].x << " " << pts[i].y << " " << pts[i].z;
        inside += truth && !b;
        boundary += b;
    }
    EXPECT_GT(inside, 10);
    EXPECT_GT(boundary, 50);
}

TEST(Inside, ManyRandomPointsInTheStairs) {
    auto e = prepare(testing::scene_of({testing::voxel_object(kStairs)}));
    std::mt19937_64 rng(12);
    std::uniform_real_distribution<double> u(-0.5, 3.5);
    std::vector<Vec3d> pts;
    for (int i = 0; i < 5000; ++i)
        pts.push_back({u(rng), u(rng), u(rng) * 0.6});
    const auto occ = classify(*e, pts);
    for (std::size_t i = 0; i < pts.size(); ++i)
        EXPECT_EQ(occ[i].inside, in_stairs(pts[i])) << i;
}

TEST(Inside, InsideAnyObject) {
    // Two overlapping closed cubes (parity each: their crossings are counted per object), an open
    // cube (winding) and a sphere.
    auto e = prepare(testing::scene_of({testing::cube_object(0, 2), testing::cube_object(1, 3),
                                        testing::open_cube_object(10, 11),
                                        testing::sphere("s", {-5, 0, 0}, 1, 0)}));
    const std::vector<Vec3d> pts = {{1.5, 1.5, 1.5},  // inside both cubes
                                    {0.5, 0.5, 0.5},  // the first only
                                    {2.5, 2.5, 2.5},  // the second only
                                    {10.5, 10.5, 10.5}, {-5, 0.5, 0}, {5, 5, 5}};
    const auto all = classify(*e, pts);
    EXPECT_TRUE(all[0].inside);
    EXPECT_TRUE(all[1].inside);
    EXPECT_TRUE(all[2].inside);
    EXPECT_TRUE(all[3].inside);
    EXPECT_NEAR(all[3].winding, 5.0 / 6.0, 1e-9);
    EXPECT_TRUE(all[4].inside);
    EXPECT_FALSE(all[5].inside);
    EXPECT_EQ(all[0].winding, 1.0);
    const auto first = classify(*e, pts, false);
    for (std::size_t i = 0; i < pts.size(); ++i)
        EXPECT_EQ(first[i].inside, all[i].inside);
}

TEST(Inside, ALoneTriangleEnclosesNothing) {
    auto e = prepare(testing::scene_of(
        {testing::mesh_object("t", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}})}));
    // Just behind the triangle (the side its normal points away from): w is nearly ½, never ½.
    const auto occ = classify(*e, {{0.2, 0.2, -1e-3}, {0.2, 0.2, 0}, {5, 5, 5}});
    EXPECT_FALSE(occ[0].inside);
    EXPECT_GT(occ[0].winding, 0.49);
    EXPECT_TRUE(occ[1].inside);  // on the surface
    EXPECT_FALSE(occ[2].inside);
}

}  // namespace
}  // namespace raycastd::engine
