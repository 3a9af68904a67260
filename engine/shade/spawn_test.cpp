#include "engine/shade/spawn.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "engine/geometry/sphere.h"
#include "engine/geometry/triangle.h"

namespace raycastd::engine {
namespace {

// Property: a ray spawned from a hit, away from the surface, never hits that surface again —
// for random hits on a sphere and a triangle near the origin and 1e6 units from it.
TEST(Spawn, SpawnedRaysDoNotHitTheirOwnSurface) {
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (double far : {0.0, 1e6}) {
        const Vec3d c{far, far * 0.5, -far};
        const Sphere s{c, 3.0};
        const Triangle tri{c + Vec3d{-5, 0, -5}, c + Vec3d{5, 0.3, -5}, c + Vec3d{0, -0.2, 5}};
        int self_hits = 0;
        for (int i = 0; i < 20000; ++i) {
            Ray ray;
            ray.origin = c + Vec3d{u(rng), 10.0, u(rng)} * 2.0;
            ray.direction = normalize(c + Vec3d{u(rng), u(rng), u(rng)} - ray.origin);
            for (int kind = 0; kind < 2; ++kind) {
                const auto hit =
                    kind == 0 ? intersect_sphere(s, ray) : intersect_triangle(tri, ray);
                if (!hit)
                    continue;
                const Vec3d p = ray.at(hit->t);
                const Vec3d err = hit_point_error(ray, *hit, {});
                // Leave on the side the ray came from (reflection) and on the far side
                // (refraction), straight along the normal and at a grazing angle.
                const Vec3d n = hit->normal;
                const Vec3d tangent = normalize(cross(n, Vec3d{0.3, 0.5, 0.7}));
                for (const Vec3d& w :
                     {n, -n, normalize(n * 1e-3 + tangent), normalize(-n * 1e-3 + tangent)}) {
                    const Ray r = spawn_ray(p, err, n, w);
                    const auto again =
                        kind == 0 ? intersect_sphere(s, r) : intersect_triangle(tri, r);
                    // Leaving a sphere outward never meets it again; going in meets the far side
                    // (t well away from 0), never the point it left.
                    if (again && again->t < 1e-3 * s.radius)
                        ++self_hits;
                }
            }
        }
        EXPECT_EQ(self_hits, 0) << "scene at " << far;
    }
}

TEST(Spawn, ShadowRayToAPointStopsShortOfIt) {
    const Ray r = spawn_ray_to({0, 0, 0}, {1e-16, 1e-16, 1e-16}, {0, 1, 0}, {0, 10, 0});
    EXPECT_GT(r.origin.y, 0.0);
    EXPECT_LT(r.tmax, 1.0);
    EXPECT_NEAR(r.at(1.0).y, 10.0, 1e-12);
}

// moved_away's step without a branch is next_up's and next_down's, bit for bit: on random sums
// of both signs and magnitudes, and where the branch-free step does not apply (a zero offset,
// a sum of zero, subnormal, huge, infinite or NaN, an offset that is NaN). A mutant stepping
// the wrong way, or forgetting the sign of the sum, fails on the random pairs.
TEST(Spawn, MovedAwayStepsAsNextUpAndNextDown) {
    const auto reference = [](double p, double offset) {
        const double po = p + offset;
        return offset > 0.0 ? next_up(po) : offset < 0.0 ? next_down(po) : po;
    };
    const auto same_bits = [](double a, double b) {
        return std::memcmp(&a, &b, sizeof a) == 0 || (std::isnan(a) && std::isnan(b));
    };
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
    std::uniform_int_distribution<int> exponent(-1074, 1023);
    int checked = 0;
    for (int i = 0; i < 200000; ++i) {
        const double p = std::ldexp(mantissa(rng), exponent(rng));
        // Offsets near p's size (the sum of either sign) and far from it.
        const double offset =
            i % 2 == 0 ? std::ldexp(mantissa(rng), exponent(rng)) : p * mantissa(rng) * 2.0;
        ASSERT_TRUE(same_bits(detail::moved_away(p, offset), reference(p, offset)))
            << p << " + " << offset;
        ++checked;
    }
    constexpr double kMax = std::numeric_limits<double>::max();
    constexpr double kMin = std::numeric_limits<double>::denorm_min();
    constexpr double kInf = std::numeric_limits<double>::infinity();
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double specials[] = {0.0, -0.0, kMin, -kMin, 1.0, -1.0, kMax, -kMax, kInf, -kInf, nan};
    for (double p : specials) {
        for (double offset : specials) {
            EXPECT_TRUE(same_bits(detail::moved_away(p, offset), reference(p, offset)))
                << p << " + " << offset;
            ++checked;
        }
    }
    // Sums that land on 0, on ±max (the step up reaches ∞) and on the smallest subnormals.
    for (double p : {1.5, -1.5, kMax, -kMax, 2 * kMin, -2 * kMin}) {
        for (double offset : {-p, -p * 0.5, p * 0.5, kMin, -kMin}) {
            EXPECT_TRUE(same_bits(detail::moved_away(p, offset), reference(p, offset)))
                << p << " + " << offset;
            ++checked;
        }
    }
    EXPECT_EQ(checked, 200000 + 121 + 30);
}

// SpawnOrigins keeps each side's origin once formed: every ray of a point, in whatever order
// its sides come (a shadow ray, a reflected ray, a refracted one behind the surface, another
// shadow ray), gets offset_ray_origin's origin for its own direction, bit for bit. Points on a
// floor (two zero normal components) and on random normals; directions on both sides and in
// the plane (w·n = 0, in front as offset_ray_origin takes it).
TEST(Spawn, OriginsFormedOnceASideAreOffsetRayOrigins) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const auto same = [](const Vec3d& a, const Vec3d& b) {
        return std::memcmp(&a.x, &b.x, sizeof(double)) == 0 &&
               std::memcmp(&a.y, &b.y, sizeof(double)) == 0 &&
               std::memcmp(&a.z, &b.z, sizeof(double)) == 0;
    };
    int sides[2] = {0, 0};
    for (int i = 0; i < 20000; ++i) {
        const Vec3d p{u(rng) * 8.0, i % 2 ? 0.0 : u(rng), u(rng) * 8.0};
        const Vec3d n = i % 2 ? Vec3d{0, 1, 0} : normalize(Vec3d{u(rng), u(rng), u(rng)});
        const Vec3d p_err = abs(p) * 4e-16 + Vec3d{1e-300, 1e-300, 1e-300};
        SpawnOrigins origins;
        for (int k = 0, rays = 1 + static_cast<int>(rng() % 6); k < rays; ++k) {
            Vec3d w{u(rng), u(rng), u(rng)};
            if (rng() % 8 == 0)
                w = w - n * dot(w, n);  // along the plane, or as near as rounding leaves it
            ++sides[leaves_behind(n, w) ? 1 : 0];
            EXPECT_TRUE(same(origins.towards(p, p_err, n, w), offset_ray_origin(p, p_err, n, w)))
                << "point " << i << ", ray " << k;
        }
    }
    EXPECT_GT(sides[0], 20000);
    EXPECT_GT(sides[1], 20000);
}

}  // namespace
}  // namespace raycastd::engine
