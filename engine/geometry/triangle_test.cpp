#include "engine/geometry/triangle.h"

#include <array>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

// The triangle a = (0,0,5), b = (2,0,5), c = (0,2,5), facing −z ((b−a)×(c−a) = (0,0,4)).
const Triangle kTri{{0, 0, 5}, {2, 0, 5}, {0, 2, 5}};

Ray toward(double x, double y) {
    return Ray{{x, y, 0}, {0, 0, 1}};
}

TEST(Triangle, Inside) {
    auto hit = intersect_triangle(kTri, toward(0.5, 0.5));
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 5.0);
    EXPECT_DOUBLE_EQ(hit->u, 0.25);  // weight of b: x / 2
    EXPECT_DOUBLE_EQ(hit->v, 0.25);  // weight of c: y / 2
    EXPECT_EQ(hit->normal, (Vec3d{0, 0, 1}));
    EXPECT_FALSE(hit->front_face);  // the ray travels along +z, with the normal
    EXPECT_FALSE(hit->on_edge);
}

TEST(Triangle, Outside) {
    EXPECT_FALSE(intersect_triangle(kTri, toward(1.5, 1.5)));
    EXPECT_FALSE(intersect_triangle(kTri, toward(-0.1, 0.5)));
}

TEST(Triangle, EdgeAndVertexAreInside) {
    auto edge = intersect_triangle(kTri, toward(1.0, 1.0));  // on the hypotenuse bc
    ASSERT_TRUE(edge);
    EXPECT_TRUE(edge->on_edge);
    auto edge_ab = intersect_triangle(kTri, toward(1.0, 0.0));
    ASSERT_TRUE(edge_ab);
    EXPECT_TRUE(edge_ab->on_edge);
    for (const Vec3d& p : {kTri.a, kTri.b, kTri.c}) {
        auto vertex = intersect_triangle(kTri, toward(p.x, p.y));
        ASSERT_TRUE(vertex) << p.x << "," << p.y;
        EXPECT_TRUE(vertex->on_edge);
        EXPECT_EQ(vertex->t, 5.0);
    }
}

TEST(Triangle, RayInPlaneMisses) {
    Ray ray{{-1, 0.5, 5}, {1, 0, 0}};
    EXPECT_FALSE(intersect_triangle(kTri, ray));
}

TEST(Triangle, ParallelOffPlaneMisses) {
    Ray ray{{-1, 0.5, 4}, {1, 0, 0}};
    EXPECT_FALSE(intersect_triangle(kTri, ray));
}

TEST(Triangle, BehindOriginMisses) {
    Ray ray{{0.5, 0.5, 10}, {0, 0, 1}};
    EXPECT_FALSE(intersect_triangle(kTri, ray));
}

TEST(Triangle, BackFaceHitIsReported) {
    Ray ray{{0.5, 0.5, 10}, {0, 0, -1}};
    auto hit = intersect_triangle(kTri, ray);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 5.0);
    EXPECT_TRUE(hit->front_face);
}

TEST(Triangle, DegenerateNeverHitsNorNaN) {
    const Triangle collinear{{0, 0, 5}, {1, 1, 5}, {2, 2, 5}};
    const Triangle point{{1, 1, 5}, {1, 1, 5}, {1, 1, 5}};
    for (const Triangle& t : {collinear, point}) {
        EXPECT_TRUE(is_degenerate(t));
        EXPECT_FALSE(intersect_triangle(t, toward(1, 1)));
        EXPECT_FALSE(intersect_triangle(t, Ray{{0, 0, 0}, {1, 1, 5}}));
        Vec3d n = triangle_normal(t);
        EXPECT_FALSE(std::isnan(n.x) || std::isnan(n.y) || std::isnan(n.z));
    }
}

TEST(Triangle, NonUnitDirection) {
    Ray ray{{0.5, 0.5, 0}, {0, 0, 10}};
    auto hit = intersect_triangle(kTri, ray);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 0.5);
}

TEST(Triangle, TErrorBoundHoldsForExactCase) {
    auto hit = intersect_triangle(kTri, Ray{{0.3, 0.2, 0}, {0.01, 0.02, 1}});
    ASSERT_TRUE(hit);
    EXPECT_LE(std::abs(hit->t - 5.0), hit->t_err);
    EXPECT_GT(hit->t_err, 0.0);
}

// An origin exactly on a vertex gets t = 0 exactly (the plane is anchored at that vertex), and
// on an axis-aligned face too.
TEST(Triangle, OriginOnSurfaceGivesExactZero) {
    const Triangle tilted{{-1.3, 0.7, 12.1}, {3.1, 2.9, 11.7}, {0.3, -2.2, 13.3}};
    for (const Vec3d& v : {tilted.a, tilted.b, tilted.c}) {
        auto hit = intersect_triangle(tilted, Ray{v, {0.3, -0.2, 1}});
        ASSERT_TRUE(hit);
        EXPECT_EQ(hit->t, 0.0);
    }
    auto hit = intersect_triangle(kTri, Ray{{0.25, 0.5, 5}, {0.1, 0.2, -1}});
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 0.0);
}

// A ray at 2⁻³ rad·2⁻³⁰ (~1e-10) to the plane z = 0.5: t = 2⁻³⁰ / 2⁻³³ = 8 exactly. Woop's
// sheared t is off by ~u/cos θ here; the plane crossing in double-double is exact.
TEST(Triangle, NearlyParallelRayExactT) {
    const Triangle big{{-10, -10, 0.5}, {10, -10, 0.5}, {-10, 10, 0.5}};
    const Ray ray{{-9, 0.1, 0.5 - std::ldexp(1.0, -30)}, {1, 0.001, std::ldexp(1.0, -33)}};
    auto hit = intersect_triangle(big, ray);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 8.0);
    EXPECT_LE(std::abs(hit->t - 8.0), hit->t_err);
}

// A sliver (angle ~1e-8 rad at a): the plane crossing of a ray through its interior, checked
// against the same formula in GCC's __float128, where the differences and the products of the
// normal are exact or nearly (long double would lose ~8 digits of the sliver's normal).
TEST(Triangle, SliverTToAnUlp) {
    const Triangle sliver{{0.3, -0.2, 4}, {2.3, 0.1, 4.2}, {1.3, -0.05 + 1e-8, 4.1}};
    const Vec3d target = sliver.a * 0.2 + sliver.b * 0.4 + sliver.c * 0.4;
    const Ray ray{{-1, 3, -2}, target - Vec3d{-1, 3, -2}};
    auto hit = triangle_plane_hit(sliver, ray);
    ASSERT_TRUE(hit);
    using Q = __float128;
    auto q = [](const Vec3d& v) { return std::array<Q, 3>{v.x, v.y, v.z}; };
    const auto a = q(sliver.a), b = q(sliver.b), c = q(sliver.c), o = q(ray.origin),
               d = q(ray.direction);
    const Q e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const Q e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const Q n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0]};
    Q num = 0, den = 0;
    for (std::size_t k = 0; k < 3; ++k) {
        num += n[k] * (a[k] - o[k]);
        den += n[k] * d[k];
    }
    const double t = static_cast<double>(num / den);
    EXPECT_LE(std::abs(hit->t - t), 2 * (std::nextafter(t, 2 * t) - t));
}

// Watertightness (Woop et al. 2013): a quad split along its diagonal; rays aimed exactly at
// points of the shared diagonal, with jittered origins, always hit at least one of the two.
TEST(Triangle, SharedEdgeNeverLeaks) {
    const Vec3d p0{0.1, 0.3, 2}, p1{3.7, 0.2, 2.5}, p2{3.3, 2.9, 3}, p3{0.2, 3.1, 2.2};
    const Triangle t0{p0, p1, p2}, t1{p0, p2, p3};
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> unit(0.0, 1.0), jitter(-5.0, 5.0);
    int leaks = 0;
    for (int i = 0; i < 20000; ++i) {
        const double s = unit(rng);
        const Vec3d target = p0 + (p2 - p0) * s;
        const Vec3d origin{jitter(rng), jitter(rng), -10.0 + jitter(rng)};
        const Ray ray{origin, target - origin};
        if (!intersect_triangle(t0, ray) && !intersect_triangle(t1, ray))
            ++leaks;
    }
    EXPECT_EQ(leaks, 0);
}

}  // namespace
}  // namespace raycastd::engine
