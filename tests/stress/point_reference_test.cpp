// The point reference itself: exact values on the unit cube, and agreement with the engine's
// double kernel (within its documented bound) on random points around an icosphere.

#include "tests/stress/point_reference.h"

#include <random>

#include <gtest/gtest.h>

#include "engine/accel/point_query.h"
#include "engine/testing/point_meshes.h"

namespace raycastd::stress {
namespace {

TEST(PointReference, ExactOnTheCube) {
    const engine::Object cube = engine::testing::cube_object(0, 1);
    const engine::TriangleMesh& m = *cube.mesh;
    EXPECT_EQ(to_double(reference_distance(m, {0.5, 0.5, 3})), 2.0);      // a face
    EXPECT_EQ(to_double(reference_distance(m, {0.5, -3, 5})), 5.0);       // an edge: 3-4-5
    EXPECT_EQ(to_double(reference_distance(m, {-2, -2, -1})), 3.0);       // a vertex
    EXPECT_EQ(to_double(reference_distance(m, {0.5, 0.25, 0.5})), 0.25);  // inside
    EXPECT_NEAR(reference_winding(m, {0.5, 0.25, 0.5}), 1.0, 1e-12);
    EXPECT_NEAR(reference_winding(m, {2, 0.25, 0.5}), 0.0, 1e-12);
}

TEST(PointReference, AgreesWithTheDoubleKernel) {
    const engine::Scene s = engine::testing::scene_of({engine::testing::icosphere_object(2)});
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(-2, 2);
    for (int i = 0; i < 500; ++i) {
        const engine::Vec3d p{u(rng), u(rng), u(rng)};
        const auto h = engine::linear_closest_point(s, p, engine::kInfinity);
        ASSERT_TRUE(h);
        EXPECT_NEAR(to_double(reference_distance(*s.objects[0].mesh, p)), h->distance, h->err);
    }
}

}  // namespace
}  // namespace raycastd::stress
