#include "engine/shade/spawn.h"

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

}  // namespace
}  // namespace raycastd::engine
