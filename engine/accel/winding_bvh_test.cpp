// Fast winding numbers against the exact sum of solid angles (Jacobson et al. 2013, brute
// force), on closed and open meshes, near and far from the surface.

#include "engine/accel/winding_bvh.h"

#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "engine/geometry/solid_angle.h"
#include "engine/mesh/test_models.h"
#include "engine/testing/point_meshes.h"

namespace raycastd::engine {
namespace {

double brute_force(const TriangleMesh& m, const Vec3d& q) {
    double w = 0;
    for (std::size_t t = 0; t < m.size(); ++t)
        w += triangle_solid_angle(m.triangle(t), q);
    return w * kInverseFourPi;
}

/// Points in the mesh's box scaled 1.6× about its centre.
std::vector<Vec3d> points_around(const TriangleMesh& m, int n, std::uint64_t seed) {
    const Bounds3 b = m.bounds();
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-0.8, 0.8);
    std::vector<Vec3d> out;
    for (int i = 0; i < n; ++i) {
        const Vec3d d = b.diagonal();
        out.push_back(b.center() + Vec3d{u(rng) * d.x, u(rng) * d.y, u(rng) * d.z});
    }
    return out;
}

double worst_error(const TriangleMesh& m, const std::vector<Vec3d>& points) {
    const WindingBvh tree(m);
    double worst = 0;
    for (const Vec3d& q : points)
        worst = std::max(worst, std::abs(tree.winding_number(q) - brute_force(m, q)));
    return worst;
}

TEST(WindingBvh, ClosedIcosphereIsOneInsideZeroOutside) {
    const Object o = testing::icosphere_object(4, {0.2, 0.1, -0.3}, 1.5);
    const WindingBvh tree(*o.mesh);
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(-3, 3);
    for (int i = 0; i < 2000; ++i) {
        const Vec3d q = Vec3d{u(rng), u(rng), u(rng)} + Vec3d{0.2, 0.1, -0.3};
        const double r = length(q - Vec3d{0.2, 0.1, -0.3});
        if (std::abs(r - 1.5) < 0.02)
            continue;  // the icosphere is not the sphere: skip the band between them
        EXPECT_NEAR(tree.winding_number(q), r < 1.5 ? 1.0 : 0.0, 1e-2) << r;
    }
}

TEST(WindingBvh, AgreesWithTheExactSum) {
    const Object ico = testing::icosphere_object(4);
    const Object open = testing::open_cube_object(-1, 1);
    const Object flipped = testing::flipped_cube_object(-1, 1, 3);
    double worst = 0;
    for (const Object* o : {&ico, &open, &flipped}) {
        const double e = worst_error(*o->mesh, points_around(*o->mesh, 3000, 2));
        EXPECT_LT(e, 1e-2);
        worst = std::max(worst, e);
    }
    std::printf("fast winding number: worst |error| %.2e on synthetic meshes\n", worst);
}

TEST(WindingBvh, AgreesWithTheExactSumOnTheBunny) {
    auto bunny = testing::model_object("stanford-bunny/stanford-bunny.obj");
    if (!bunny)
        GTEST_SKIP() << "models not found at " << testing::models_dir();
    const double e = worst_error(*bunny->mesh, points_around(*bunny->mesh, 400, 3));
    std::printf("fast winding number: worst |error| %.2e on the Stanford bunny\n", e);
    EXPECT_LT(e, 1e-2);
}

TEST(WindingBvh, EmptyAndDegenerateMeshesWindZero) {
    TriangleMesh m;
    EXPECT_EQ(WindingBvh(m).winding_number({0, 0, 0}), 0.0);
    m.positions = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}};
    m.triangles = {{0, 1, 2}};
    EXPECT_EQ(WindingBvh(m).winding_number({0, 1, 0}), 0.0);
}

}  // namespace
}  // namespace raycastd::engine
