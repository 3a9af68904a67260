// Inside/outside object by object: parity rays through edges and along face planes (a
// non-convex voxel solid, where a ray from a point in a face's plane slides along that face),
// several objects at once, and the sphere and on-surface rules.

#include "engine/points/inside.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "engine/points/point_queries.h"
#include "engine/query/parity_pieces.h"
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
    EXPECT_TRUE(classify_points(e, pts.data(), NearestHits(nearest.data()), pts.size(), all_objects,
                                {}, out.data())
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

TEST(Inside, ComponentsOfOneMeshEachCountWhereTheirBoxesHoldThePoint) {
    // One closed mesh of five spheres: a hollow ball (the sphere of radius 2 about the origin and
    // one of radius 1 inside it), a lone sphere, and two that overlap. Crossing parity puts the
    // shell between the hollow ball's surfaces inside, its cavity outside, and the lens where
    // the two overlap outside (two surfaces around it): the test counts only the components
    // whose boxes hold a point (mesh/components.h), so each of these asks for the sum over
    // several pieces, and a point in no box for no ray at all. A sixth small ball straddles the
    // corner of the big one's box, outside the big sphere: rays from points near that corner
    // end inside it, crossing it once, and that crossing must not count for them.
    const std::vector<testing::Ball> balls = {{{0, 0, 0}, 2.0},   {{0, 0, 0}, 1.0},
                                              {{5, 0, 0}, 1.0},   {{0, 5, 0}, 1.0},
                                              {{0.8, 5, 0}, 1.0}, {{1.9, 1.9, 0}, 0.4}};
    const Object o = testing::balls_object(balls, 3);
    auto e = prepare(testing::scene_of({o}));
    ASSERT_TRUE(e);
    ASSERT_EQ(e->topology()[0].sign, SignMethod::parity);
    ASSERT_EQ(e->topology()[0].components, 6u);

    // The truth: how many balls hold p, for points clearly inside (0.98 r: a level-3 icosphere's
    // faces are all beyond 0.99 r of its centre) or outside (beyond r) each of them.
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> ux(-3, 7), uy(-3, 7), uz(-3, 3);
    std::vector<Vec3d> pts;
    std::vector<int> want;
    while (pts.size() < 25000) {
        const Vec3d p{ux(rng), uy(rng), uz(rng)};
        int in = 0;
        bool clear = true;
        for (const testing::Ball& b : balls) {
            const double d = length(p - b.centre);
            in += d < 0.98 * b.radius;
            clear = clear && (d < 0.98 * b.radius || d > b.radius);
        }
        if (clear) {
            pts.push_back(p);
            want.push_back(in % 2);
        }
    }
    // Points of each kind were drawn: the shell, the cavity, the lens, the lone ball, outside.
    auto count_in = [&](const Vec3d& c, double lo, double hi) {
        return std::count_if(pts.begin(), pts.end(), [&](const Vec3d& p) {
            const double d = length(p - c);
            return d > lo && d < hi;
        });
    };
    ASSERT_GT(count_in({0, 0, 0}, 1.0, 1.96), 50);
    ASSERT_GT(count_in({0, 0, 0}, 0.0, 0.98), 10);
    ASSERT_GT(count_in({0.4, 5, 0}, 0.0, 0.5), 10);
    const std::vector<Occupancy> occ = classify(*e, pts);
    for (std::size_t i = 0; i < pts.size(); ++i) {
        ASSERT_EQ(occ[i].inside, want[i] == 1)
            << "point " << i << " (" << pts[i].x << ", " << pts[i].y << ", " << pts[i].z << ")";
    }
    // The pieces were built, one per component, and are counted in the engine's memory.
    EXPECT_EQ(e->parity_pieces().object.size(), 6u);
    EXPECT_GE(e->memory_bytes(), e->parity_pieces().memory_bytes());
}

TEST(Inside, ManyNestedComponentsHoldingOnePoint) {
    // 18 concentric spheres in one mesh: a point near the centre is in all 18 boxes (more than
    // the seven pieces a point keeps in place, more than the 16 counts kept on the stack), and
    // inside exactly when an odd number of the spheres surround it.
    const int kShells = 18;
    std::vector<testing::Ball> shells;
    for (int k = 1; k <= kShells; ++k)
        shells.push_back({{0, 0, 0}, double(k)});
    auto e = prepare(testing::scene_of({testing::balls_object(shells, 2)}));
    ASSERT_TRUE(e);
    ASSERT_EQ(e->topology()[0].sign, SignMethod::parity);
    std::mt19937_64 rng(5);
    std::normal_distribution<double> g;
    std::uniform_real_distribution<double> radius(0.0, kShells + 1.0);
    std::vector<Vec3d> pts;
    std::vector<int> want;
    while (pts.size() < 3000) {
        // A level-2 icosphere of radius k lies between 0.987 k and k from its centre: points
        // within 2.5% below a radius are not drawn.
        const double r = pts.size() < 300 ? radius(rng) * 0.05 : radius(rng);
        if (r - std::floor(r) == 0 || r > 0.975 * (std::floor(r) + 1))
            continue;
        pts.push_back(normalize(Vec3d{g(rng), g(rng), g(rng)}) * r);
        want.push_back((kShells - static_cast<int>(std::floor(r))) % 2);
    }
    const std::vector<Occupancy> occ = classify(*e, pts);
    for (std::size_t i = 0; i < pts.size(); ++i)
        ASSERT_EQ(occ[i].inside, want[i] == 1) << "point " << i << " at radius " << length(pts[i]);
}

}  // namespace
}  // namespace raycastd::engine
