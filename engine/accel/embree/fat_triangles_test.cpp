// refined's widened triangles (fat_triangles.h): the widened triangle holds every point of the
// plane within w of the triangle, slivers are capped, and refined answers misses of a certified
// scene in one traversal (the exact BVH is never built for them).

#include "engine/accel/embree/fat_triangles.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "engine/accel/embree_accel.h"
#include "engine/testing/scenes.h"

namespace raycastd::engine::embree {
namespace {

/// Signed distances of p (in the plane of a, b, c) from the three edge lines, positive inside.
std::array<double, 3> edge_distances(const Vec3d& a, const Vec3d& b, const Vec3d& c,
                                     const Vec3d& p) {
    const Vec3d n = normalize(cross(b - a, c - a));
    const Vec3d v[3] = {a, b, c};
    std::array<double, 3> d{};
    for (int i = 0; i < 3; ++i) {
        const Vec3d e = normalize(v[(i + 1) % 3] - v[i]);
        d[i] = dot(cross(n, e), p - v[i]);  // n × e points into a counter-clockwise triangle
    }
    return d;
}

TEST(FatTriangles, WidenedTriangleHoldsTheNeighbourhood) {
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> u(-1, 1), unit(0, 1);
    const double w = 1e-3;
    int tested = 0;
    for (int k = 0; k < 2000; ++k) {
        const Triangle t{
            {u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}};
        Vec3d out[3];
        bool capped = false;
        widen_triangle(t, w, out, capped);
        if (capped)
            continue;
        ++tested;
        // The widened edges are the triangle's, moved out by w: every corner is at distance w
        // beyond the two edges it lies on.
        const auto da = edge_distances(t.a, t.b, t.c, out[0]);
        EXPECT_NEAR(da[0], -w, 1e-12);
        EXPECT_NEAR(da[2], -w, 1e-12);
        // A point of the triangle moved by less than w in the plane lies in the widened one.
        double s = unit(rng), r = unit(rng);
        if (s + r > 1) {
            s = 1 - s;
            r = 1 - r;
        }
        const Vec3d n = normalize(cross(t.b - t.a, t.c - t.a));
        Vec3d off = cross(n, Vec3d{u(rng), u(rng), u(rng)});
        off = normalize(off) * (0.999 * w * unit(rng));
        const Vec3d p = t.a + (t.b - t.a) * s + (t.c - t.a) * r + off;
        const auto d = edge_distances(out[0], out[1], out[2], p);
        EXPECT_GE(std::min({d[0], d[1], d[2]}), -1e-12) << k;
    }
    EXPECT_GT(tested, 1500);
}

TEST(FatTriangles, SliverCornersAreCapped) {
    Vec3d out[3];
    bool capped = false;
    widen_triangle(Triangle{{0, 0, 0}, {1, 0, 0}, {0.5, 0.8, 0}}, 1e-3, out, capped);
    EXPECT_FALSE(capped);
    // A corner of ~1°: its bisector offset w/sin(0.5°) would be 115 w.
    widen_triangle(Triangle{{0, 0, 0}, {1, 0, 0}, {1, 0.0175, 0}}, 1e-3, out, capped);
    EXPECT_TRUE(capped);
    EXPECT_LE(length(out[0] - Vec3d{0, 0, 0}), 1e-3 / kMinCornerSine * (1 + 1e-12));
}

// A certified scene answers refined's misses from the one float traversal: rays that pass the
// icosphere by a little (or meet nothing but its bounds) never build the exact BVH, which the
// accelerator's memory would show; rays aimed at its vertices still agree with exact.
TEST(FatTriangles, RefinedMissesNeedNoSecondTraversal) {
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(testing::icosphere_object(3, {0, 0, 0}, 1.0));
    auto accel = EmbreeAccel::build(s);
    ASSERT_TRUE(accel.ok());
    const EmbreeAccel& a = **accel;
    const std::size_t before = a.memory_bytes();
    std::vector<Ray> rays;
    for (int i = 0; i < 64; ++i) {
        const double phi = 0.1 * i;
        // Parallel to z, passing 1.001 from the centre: outside the sphere's circumscribed mesh.
        rays.push_back(Ray{{1.001 * std::cos(phi), 1.001 * std::sin(phi), -5}, {0, 0, 1}});
    }
    std::vector<Hit> out(rays.size());
    a.closest_range(rays.data(), rays.size(), Precision::refined, true, out.data());
    for (const Hit& h : out)
        EXPECT_FALSE(h.valid());
    std::vector<std::uint8_t> blocked(rays.size(), 2);
    a.any_range(rays.data(), rays.size(), Precision::refined, blocked.data());
    for (std::uint8_t b : blocked)
        EXPECT_EQ(b, 0);
    EXPECT_EQ(a.memory_bytes(), before) << "a miss was confirmed on the exact BVH";

    const TriangleMesh& m = *s.objects[0].mesh;
    for (std::size_t i = 0; i < m.positions.size(); ++i) {
        const Vec3d o = m.positions[i] * 3.0 + Vec3d{0.1, -0.2, 0.05} * static_cast<double>(i % 3);
        const Ray r{o, m.positions[i] - o};
        const auto refined = a.closest(r, Precision::refined, false);
        const auto exact = a.closest(r, Precision::exact, false);
        ASSERT_TRUE(refined && exact) << i;
        EXPECT_NEAR(refined->t, exact->t, refined->t_err + exact->t_err) << i;
    }
}

// crossed_well_inside on a thin triangle, whose three edges (10, 1 and 10.05 long) tell a
// pairing of barycentric and edge apart: a point just inside and just outside the inset of each
// edge in turn, and the inset growing as the line tilts.
TEST(FatTriangles, CrossedWellInsideMeasuresFromEachEdge) {
    const Triangle t{{0, 0, 0}, {10, 0, 0}, {0, 1, 0}};
    const Vec3d down{0, 0, -1};
    const double delta = 0.025;  // head-on: inset 2Δ + 2Δ = 0.1
    // (x, y) is at barycentrics u = x/10 (b's weight), v = y (c's).
    auto inside = [&](double x, double y, const Vec3d& d) {
        return crossed_well_inside(t, x / 10.0, y, d, delta);
    };
    EXPECT_TRUE(inside(0.5, 0.2, down));
    EXPECT_TRUE(inside(0.5, 0.11, down));   // 0.11 from ab (y = 0)
    EXPECT_FALSE(inside(0.5, 0.09, down));  // 0.09 from it
    EXPECT_TRUE(inside(0.11, 0.5, down));   // from ac (x = 0)
    EXPECT_FALSE(inside(0.09, 0.5, down));
    // bc: x + 10y = 10, |(1, 10)| = √101; a point s from it along its inward normal.
    const double r101 = std::sqrt(101.0);
    auto off_bc = [&](double s) {
        const Vec3d on{5, 0.5, 0};
        return on - Vec3d{1, 10, 0} * (s / r101);
    };
    EXPECT_TRUE(inside(off_bc(0.11).x, off_bc(0.11).y, down));
    EXPECT_FALSE(inside(off_bc(0.09).x, off_bc(0.09).y, down));
    // Tilted to sin β = 1/2 the inset is 2Δ·2 + 2Δ = 0.15; below sin β = 1/16, nothing passes.
    const Vec3d tilted{std::sqrt(3.0) / 2.0, 0, -0.5};
    EXPECT_TRUE(inside(0.5, 0.16, tilted));
    EXPECT_FALSE(inside(0.5, 0.14, tilted));
    EXPECT_FALSE(inside(0.5, 0.3, Vec3d{1, 0, -0.06}));
    EXPECT_FALSE(inside(0.5, 0.3, Vec3d{0, 0, 0}));  // no direction: NaN
}

}  // namespace
}  // namespace raycastd::engine::embree
