// The reference itself: exact answers worked out by hand, margin signs, and the classification
// of ties. If these fail, nothing the stress suites say can be trusted.

#include "tests/stress/reference.h"

#include <gtest/gtest.h>
#include <quadmath.h>

#include "engine/testing/scenes.h"
#include "tests/stress/generators.h"

namespace raycastd::stress {
namespace {

using engine::Ray;
using engine::Scene;
using engine::Vec3d;

Quad qabs(Quad v) {
    return v < 0 ? -v : v;
}

Scene one(engine::Object o) {
    Scene s = empty_scene();
    s.objects.push_back(std::move(o));
    return s;
}

// Tutorial Question 1, sphere 3: t = 9 ∓ √3, here to quad precision.
TEST(Reference, TutorialSphereToQuadPrecision) {
    const Scene s = one(sphere({0, 1, 9}, 2));
    const auto xs = reference_crossings(s, Ray{{0, 0, 0}, {0, 0, 1}}, exact_bands());
    ASSERT_EQ(xs.size(), 2u);
    const Quad near = xs[0].t < xs[1].t ? xs[0].t : xs[1].t;
    const Quad truth = Quad(9) - sqrtq(Quad(3));
    EXPECT_LT(to_double(qabs(near - truth)), 1e-32);
    EXPECT_GT(xs[0].margin, 0.05);  // (r − dist)/(|f| + r) = 1/(√82 + 2)
}

// A unit sphere at 1e8: both roots 1e8 ∓ 1 exactly, which the textbook formula in double loses.
TEST(Reference, FarSphereRootsExact) {
    const Scene s = one(sphere({0, 0, 1e8}, 1));
    const auto xs = reference_crossings(s, Ray{{0, 0, 0}, {0, 0, 1}}, exact_bands());
    ASSERT_EQ(xs.size(), 2u);
    for (const RefCrossing& c : xs) {
        const Quad want = c.front_face ? Quad(1e8 - 1) : Quad(1e8 + 1);
        EXPECT_EQ(to_double(c.t - want), 0.0);
    }
}

// Exactly tangent: one candidate at the closest approach, margin exactly 0 (a near-tie).
TEST(Reference, TangentIsANearTie) {
    const Scene s = one(sphere({0, 1, 5}, 1));
    const Ray ray{{0, 0, 0}, {0, 0, 1}};
    const auto xs = reference_crossings(s, ray, exact_bands());
    ASSERT_EQ(xs.size(), 1u);
    EXPECT_EQ(xs[0].margin, 0.0);
    EXPECT_EQ(to_double(xs[0].t), 5.0);
    const RefAnswer a = reference_closest(s, ray, exact_bands(), {});
    EXPECT_TRUE(a.hit);  // the API: a tangent ray hits once
    EXPECT_FALSE(a.hit_robust);
}

TEST(Reference, TriangleMarginSigns) {
    const Scene s = one(triangle({0, 0, 5}, {2, 0, 5}, {0, 2, 5}));
    auto margin = [&](double x, double y) {
        const auto xs = reference_crossings(s, Ray{{x, y, 0}, {0, 0, 1}}, float_bands());
        return xs.empty() ? -1.0 : xs[0].margin;
    };
    EXPECT_GT(margin(0.5, 0.5), 0.01);
    EXPECT_EQ(margin(1.0, 1.0), 0.0);  // on the hypotenuse
    EXPECT_EQ(margin(0.0, 0.0), 0.0);  // on a vertex
    EXPECT_LT(margin(1.5, 1.5), 0.0);
    const auto xs = reference_crossings(s, Ray{{0.5, 0.5, 0}, {0, 0, 2}}, exact_bands());
    ASSERT_EQ(xs.size(), 1u);
    EXPECT_EQ(to_double(xs[0].t), 2.5);  // t in units of the direction as given
    EXPECT_FALSE(xs[0].front_face);      // travelling along (b−a)×(c−a) = +z
}

TEST(Reference, ClosedMeshDetection) {
    EXPECT_TRUE(is_closed_mesh(*engine::testing::cube_object(-1, 1).mesh));
    EXPECT_TRUE(is_closed_mesh(*engine::testing::icosphere_object(2).mesh));
    engine::TriangleMesh open = *engine::testing::cube_object(-1, 1).mesh;
    open.triangles.pop_back();
    EXPECT_FALSE(is_closed_mesh(open));
}

// A ray through a shared edge of a closed cube enters it robustly although each of the two
// triangles only touches the ray at its edge; a ray along a silhouette edge does not.
TEST(Reference, ClosedMeshEdgeCrossingIsRobust) {
    Scene s = one(engine::testing::cube_object(-1, 1));
    const std::vector<bool> closed{true};
    // Through the diagonal shared by the two triangles of the z = −1 face.
    const RefAnswer a = reference_closest(s, Ray{{0, 0, -5}, {0, 0, 1}}, exact_bands(), closed);
    EXPECT_TRUE(a.hit);
    EXPECT_TRUE(a.hit_robust);
    EXPECT_EQ(to_double(a.t), 4.0);
    // Grazing along the edge x = 1, y = 1: touches, never enters.
    const RefAnswer g = reference_closest(s, Ray{{1, 1, -5}, {0, 0, 1}}, exact_bands(), closed);
    EXPECT_FALSE(g.hit_robust);
}

// Two objects at exactly the same t: the hit is robust, which object comes first is not.
TEST(Reference, ExactTieBetweenObjectsIsNotJudged) {
    Scene s = empty_scene();
    s.objects.push_back(triangle({-1, -1, 3}, {2, -1, 3}, {-1, 2, 3}));
    s.objects.push_back(triangle({-1, -1, 3}, {2, -1, 3}, {-1, 2, 3}));
    const RefAnswer a = reference_closest(s, Ray{{0, 0, 0}, {0, 0, 1}}, exact_bands(), {});
    EXPECT_TRUE(a.hit_robust);
    EXPECT_FALSE(a.object_robust);
    EXPECT_EQ(a.object, 0u);  // exact answer by the API's tie rule
}

TEST(Reference, UlpOfDouble) {
    EXPECT_EQ(ulp(1.0), std::ldexp(1.0, -52));
    EXPECT_EQ(ulp(-1.5), std::ldexp(1.0, -52));
    EXPECT_EQ(ulp(0.0), std::numeric_limits<double>::denorm_min());
}

}  // namespace
}  // namespace raycastd::stress
