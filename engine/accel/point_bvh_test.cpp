// PointBvh: its float lower bound never exceeds a triangle's distance, and its answers are brute
// force's, bit for bit, on random scenes, on the regions of an icosphere (vertices, edges, faces,
// the surface itself, the centre where every triangle nearly ties, far points), on ties and on
// slivers.

#include "engine/accel/point_bvh.h"

#include <random>

#include <gtest/gtest.h>

#include "engine/accel/point_query.h"
#include "engine/math/float_bounds.h"
#include "engine/testing/expect_point_hit.h"
#include "engine/testing/point_meshes.h"

namespace raycastd::engine {
namespace {

using testing::expect_same_point_hit;

// The brute-force references below cost ~11x release's time under ASan+UBSan with libFuzzer's
// coverage (59 s for the icosphere test, 47 s for the random scenes, stop 37's clean-clone run,
// the asan stage's two slowest tests). The sanitizers look for memory and undefined-behaviour
// errors, which a quarter of the points reach as well: every region kind and every far-point
// scale is still visited. The release build checks every point.
#if RAYCASTD_SANITIZED
constexpr int kEveryNth = 4;
#else
constexpr int kEveryNth = 1;
#endif

TEST(PointBvh, LowerBoundNeverExceedsTheDistance) {
    std::mt19937_64 rng(18);
    std::uniform_real_distribution<double> u(-1, 1);
    std::uniform_int_distribution<int> kind(0, 6);
    int tight = 0, tight_double = 0, face = 0, invalid = 0;
    const int kPairs = 200000;
    for (int i = 0; i < kPairs; ++i) {
        const double size = std::pow(10.0, 3 * u(rng));  // 1e-3 .. 1e3
        const Vec3d centre{u(rng) * 10, u(rng) * 10, u(rng) * 10};
        Vec3d a = Vec3d{u(rng), u(rng), u(rng)} * size, b = Vec3d{u(rng), u(rng), u(rng)} * size,
              c = Vec3d{u(rng), u(rng), u(rng)} * size;
        if (kind(rng) == 0)  // a sliver: c almost on the line ab
            c = a + (b - a) * u(rng) + Vec3d{u(rng), u(rng), u(rng)} * (size * 1e-9);
        const Triangle abs_tri{a + centre, b + centre, c + centre};
        if (is_degenerate(abs_tri))
            continue;
        // Points: near, on the plane, at the vertices and edges, far.
        Vec3d p;
        switch (kind(rng)) {
            case 0:
                p = a + (b - a) * u(rng) * 1.5;
                break;
            case 1:
                p = a * 0.3 + b * 0.3 + c * 0.4 + Vec3d{u(rng), u(rng), u(rng)} * (size * 1e-6);
                break;
            case 2:
                p = Vec3d{u(rng), u(rng), u(rng)} *
                    (size * std::pow(10.0, 2 + 6 * std::abs(u(rng))));
                break;
            case 3: {
                // On the border between corner a's region and edge ab's: out along ab's outward
                // normal from a, nudged either way along ab, and off the plane.
                const Vec3d n = normalize(cross(b - a, c - a));
                const Vec3d m = normalize(cross(b - a, n));
                p = a + m * (size * std::abs(u(rng))) + (b - a) * (1e-7 * u(rng)) +
                    n * (size * u(rng));
                break;
            }
            default:
                p = Vec3d{u(rng), u(rng), u(rng)} * (size * 2);
        }
        const Triangle rel{abs_tri.a - centre, abs_tri.b - centre, abs_tri.c - centre};
        const Vec3d pc = (p + centre) - centre;
        const double scale = 2 * std::max({max_abs(rel.a), max_abs(rel.b), max_abs(rel.c)});
        const TrianglePlanes t =
            triangle_planes(rel.a, rel.b, rel.c, 8.0 * kFloatUnitRoundoff * scale);
        PlanePack pack;
        set_lane(pack, 0, t);
        const float q[3] = {float(pc.x), float(pc.y), float(pc.z)};
        const double qmax = max_abs(Vec3d{q[0], q[1], q[2]});
        const float eps = float_up(float_margins(qmax, scale).plane);
        float lb2[4];
        lower_bounds2(pack, q, eps, lb2);
        // The far walk's bounds in double, from the same point.
        const double qd[3] = {pc.x, pc.y, pc.z};
        double lbd[4];
        lower_bounds2(pack, qd, double_margins(max_abs(pc), scale), lbd);
        const auto cp = closest_point_on_triangle(abs_tri, p + centre);
        ASSERT_TRUE(cp);
        const double d = cp->distance + cp->err;
        SCOPED_TRACE(i);
        EXPECT_LE(double(lb2[0]), d * d * (1.0 + 1.0 / (1 << 16)));
        EXPECT_LE(lbd[0], d * d * (1.0 + 1.0 / (1 << 16)));
        if (t.plane[0] == 0 && t.plane[1] == 0 && t.plane[2] == 0) {
            ++invalid;
        } else if (cp->u > 1e-3 && cp->v > 1e-3 && cp->u + cp->v < 1 - 1e-3 &&
                   cp->distance > 1e-3 * size) {
            ++face;
            tight += std::sqrt(double(lb2[0])) >= 0.999 * cp->distance;
            tight_double += std::sqrt(lbd[0]) >= 0.999 * cp->distance;
        }
    }
    // The bound is the distance itself in the face region (up to ε), and slivers are rare.
    EXPECT_GE(tight, face * 95 / 100);
    EXPECT_GE(tight_double, face * 99 / 100);
    EXPECT_LT(invalid, kPairs / 20);
}

TEST(PointBvh, AgreesWithBruteForceOnRandomScenes) {
    for (double offset : {0.0, 1e5}) {
        const Scene s = testing::random_scene(5, offset);
        ASSERT_TRUE(PointBvh::suits(s));
        const PointBvh tree(s);
        std::mt19937_64 rng(7);
        std::uniform_real_distribution<double> pos(-9, 9);
        for (int i = 0; i < 20000; i += kEveryNth) {
            // Some far points (the double walk from 64 S), some beyond any walk (brute force).
            const double scale = i % 10 == 0   ? std::pow(10.0, 1 + i % 9)
                                 : i % 97 == 0 ? 1e120
                                               : 1.0;
            const Vec3d p =
                Vec3d{pos(rng), pos(rng), pos(rng)} * scale + Vec3d{offset, offset, offset};
            const double reach = i % 3 == 0 ? 1.5 : kInfinity;
            SCOPED_TRACE(i);
            expect_same_point_hit(tree.closest_point(p, reach), linear_closest_point(s, p, reach));
        }
    }
}

TEST(PointBvh, AgreesWithBruteForceOnAnIcosphereRegionByRegion) {
    const Scene s = testing::scene_of({testing::icosphere_object(4, {0.3, -0.2, 0.1}, 2.0)});
    const PointBvh tree(s);
    const TriangleMesh& m = *s.objects[0].mesh;
    const Vec3d c{0.3, -0.2, 0.1};
    std::vector<Vec3d> pts = {c, c + Vec3d{1e-9, 0, 0}, c + Vec3d{1e3, 1e3, 1e3}};
    for (std::size_t k = 0; k < m.triangles.size(); k += 7 * kEveryNth) {
        const auto& t = m.triangles[k];
        const Vec3d a = m.positions[t[0]], b = m.positions[t[1]], d = m.positions[t[2]];
        // The vertex, an edge's midpoint, the centroid (on the surface), and each pushed
        // radially in and out (vertex, edge and face regions from both sides).
        for (const Vec3d& x : {a, (a + b) * 0.5, (a + b + d) / 3.0}) {
            pts.push_back(x);
            for (double f : {0.0, 0.3, 0.999, 1.001, 1.5, 40.0})
                pts.push_back(c + (x - c) * f);
        }
    }
    for (std::size_t i = 0; i < pts.size(); ++i) {
        SCOPED_TRACE(i);
        const auto h = tree.closest_point(pts[i], kInfinity);
        expect_same_point_hit(h, linear_closest_point(s, pts[i], kInfinity));
    }
}

TEST(PointBvh, ATreeBuiltInParallelAgreesWithBruteForce) {
    // 20,480 triangles: subtrees of 16,384 and more are built on two threads.
    const Scene s = testing::scene_of({testing::icosphere_object(5, {0.1, 0.2, -0.3}, 1.5)});
    const PointBvh tree(s);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> pos(-2.5, 2.5);
    for (int i = 0; i < 400; ++i) {
        const Vec3d p{pos(rng), pos(rng), pos(rng)};
        SCOPED_TRACE(i);
        expect_same_point_hit(tree.closest_point(p, kInfinity),
                              linear_closest_point(s, p, kInfinity));
    }
}

TEST(PointBvh, TiesGoToTheLowerObjectThenTheLowerPrimitive) {
    // Mirrored triangles about z = 0 in objects 1 and 2 with a point on the mirror; the same
    // triangle twice in one mesh (primitives 12 and 13 of the cube's copy); far cubes so the
    // scene is above 16 primitives.
    Object upper = testing::mesh_object("up", {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}}, {{0, 1, 2}});
    Object lower = testing::mesh_object("down", {{0, 0, -1}, {1, 0, -1}, {0, 1, -1}}, {{0, 2, 1}});
    Object twice = testing::cube_object(5, 6);
    auto m = std::make_shared<TriangleMesh>(*twice.mesh);
    m->triangles.push_back(m->triangles[3]);
    twice.mesh = m;
    for (bool swap : {false, true}) {
        Scene s = testing::scene_of(
            {testing::cube_object(50, 51), swap ? lower : upper, swap ? upper : lower, twice});
        const PointBvh tree(s);
        for (const Vec3d& p : {Vec3d{0.25, 0.25, 0}, Vec3d{-1, -1, 0}, Vec3d{2, 0.1, 0},
                               Vec3d{5.5, 5.5, 7}, Vec3d{5.2, 5.7, 6.5}, Vec3d{5.5, 5.5, 5.5}}) {
            SCOPED_TRACE(p.x + p.y);
            expect_same_point_hit(tree.closest_point(p, kInfinity),
                                  linear_closest_point(s, p, kInfinity));
        }
        const auto h = tree.closest_point({0.25, 0.25, 0}, kInfinity);
        ASSERT_TRUE(h);
        EXPECT_EQ(h->object, 1u);
    }
}

TEST(PointBvh, SliversAreDecidedExactly) {
    // Needles and near-degenerate fans around a good triangle: their planes may be invalid (a
    // bound of 0), never wrong.
    std::vector<Vec3d> v = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    std::vector<std::array<std::uint32_t, 3>> t = {{0, 1, 2}};
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<double> u(-1, 1);
    for (std::uint32_t k = 0; k < 64; ++k) {
        const Vec3d a{u(rng), u(rng), u(rng)}, b{u(rng), u(rng), u(rng)};
        const Vec3d c = a + (b - a) * u(rng) + Vec3d{u(rng), u(rng), u(rng)} * 1e-12;
        v.insert(v.end(), {a, b, c});
        t.push_back({3 * k + 3, 3 * k + 4, 3 * k + 5});
    }
    const Scene s = testing::scene_of({testing::mesh_object("slivers", v, t)});
    const PointBvh tree(s);
    for (int i = 0; i < 5000; ++i) {
        const Vec3d p{u(rng) * 2, u(rng) * 2, u(rng) * 2};
        SCOPED_TRACE(i);
        expect_same_point_hit(tree.closest_point(p, kInfinity),
                              linear_closest_point(s, p, kInfinity));
    }
}

TEST(PointBvh, NotFiniteAndOutOfReach) {
    const Scene s = testing::scene_of({testing::icosphere_object(2)});
    const PointBvh tree(s);
    EXPECT_FALSE(tree.closest_point({std::nan(""), 0, 0}, kInfinity));
    EXPECT_FALSE(tree.closest_point({kInfinity, 0, 0}, kInfinity));
    EXPECT_FALSE(tree.closest_point({3, 0, 0}, 1.5));
    expect_same_point_hit(tree.closest_point({3, 0, 0}, 2.5),
                          linear_closest_point(s, {3, 0, 0}, 2.5));
    EXPECT_GT(tree.memory_bytes(), s.triangle_count() * 64);
}

}  // namespace
}  // namespace raycastd::engine
