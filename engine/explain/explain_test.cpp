#include "engine/explain/explain.h"

#include <cmath>
#include <regex>

#include <gtest/gtest.h>

#include "engine/query/intersect.h"
#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

// The tutorial's worked solution of Question 1, number for number.
TEST(Explain, TutorialQuestion1) {
    Explanation ex = explain(testing::tutorial_spheres(), Ray{{0, 0, 0}, {0, 0, 1}}).value();
    ASSERT_EQ(ex.objects.size(), 3u);

    const ObjectWork& s1 = ex.objects[0];
    EXPECT_EQ(s1.name, "sphere 1");
    ASSERT_TRUE(s1.sphere);
    EXPECT_EQ(s1.sphere->a, 1.0);
    EXPECT_EQ(s1.sphere->b, -20.0);
    EXPECT_EQ(s1.sphere->c, 96.0);
    EXPECT_EQ(s1.sphere->discriminant, 16.0);
    EXPECT_EQ(s1.sphere->roots, (std::vector<double>{8.0, 12.0}));
    EXPECT_TRUE(s1.hit);
    EXPECT_EQ(*s1.t, 8.0);
    EXPECT_NE(std::find(s1.steps.begin(), s1.steps.end(), "(0-0)^2+(0-0)^2+(t-10)^2 = 2^2"),
              s1.steps.end());
    EXPECT_NE(std::find(s1.steps.begin(), s1.steps.end(), "t^2 - 20t + 96 = 0"), s1.steps.end());

    const ObjectWork& s2 = ex.objects[1];
    EXPECT_FALSE(s2.hit);
    EXPECT_TRUE(s2.sphere->roots.empty());
    EXPECT_EQ(s2.reason, "no real roots: the ray misses");
    EXPECT_NE(std::find(s2.steps.begin(), s2.steps.end(), "(0-0)^2+(0-3)^2+(t-8)^2 = 2^2"),
              s2.steps.end());

    const ObjectWork& s3 = ex.objects[2];
    EXPECT_EQ(s3.sphere->discriminant, 12.0);
    ASSERT_EQ(s3.sphere->roots.size(), 2u);
    EXPECT_NEAR(s3.sphere->roots[1], 9 + std::sqrt(3.0), 1e-14);

    ASSERT_TRUE(ex.first_hit);
    EXPECT_EQ(ex.first_hit->object, 2u);
    EXPECT_EQ(ex.first_hit->t, 7.267949192431123);
    EXPECT_EQ(ex.first_point, (Vec3d{0, 0, 7.267949192431123}));
}

// A ray from the centre of the tutorial's sphere 1 meets it behind and ahead: t = −2 or t = 2
// (β = 0, where the double-double kernel had given 2 twice), and with tmin = 0 the hit is at 2.
TEST(Explain, ARayFromASpheresCentreHasRootsOfBothSigns) {
    Scene scene;
    scene.materials.push_back(Material{});
    scene.material_names.push_back("default");
    scene.objects.push_back(testing::sphere("sphere 1", {0, 0, 10}, 2.0, 0));
    const Explanation ex = explain(scene, Ray{{0, 0, 10}, {0, 0, 1}}).value();
    ASSERT_EQ(ex.objects.size(), 1u);
    const ObjectWork& w = ex.objects[0];
    ASSERT_TRUE(w.sphere);
    EXPECT_EQ(w.sphere->roots, (std::vector<double>{-2.0, 2.0}));
    EXPECT_NE(std::find(w.steps.begin(), w.steps.end(), "t = -2 or t = 2"), w.steps.end());
    ASSERT_TRUE(w.hit);
    EXPECT_EQ(*w.t, 2.0);
}

// The tutorial's Question 3 method on a triangle: n = ac × ab, plane, t, d, cross products.
TEST(Explain, TriangleByThePlaneMethod) {
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(
        testing::mesh_object("abc", {{0, 0, 5}, {2, 0, 5}, {0, 2, 5}}, {{0, 1, 2}}));
    Explanation ex = explain(s, Ray{{0.5, 0.5, 0}, {0, 0, 1}}).value();
    const ObjectWork& w = ex.objects[0];
    ASSERT_TRUE(w.triangle);
    // ac × ab = (0,2,0) × (2,0,0) = (0,0,−4)
    EXPECT_EQ(w.triangle->normal, (Vec3d{0, 0, -4}));
    EXPECT_EQ(w.triangle->plane_d, -20.0);
    EXPECT_EQ(*w.triangle->t, 5.0);
    EXPECT_TRUE(w.triangle->same_direction);
    EXPECT_TRUE(w.hit);
    // For an inside point all three cross products point the same way, here along +z (the
    // winding of abc seen from the ray's side): da×db = (−.5,−.5,0)×(1.5,−.5,0) = (0,0,1).
    for (const Vec3d& c : w.triangle->cross)
        EXPECT_GT(c.z, 0.0);
    EXPECT_EQ(w.triangle->cross[0], (Vec3d{0, 0, 1}));

    Explanation miss = explain(s, Ray{{1.5, 1.5, 0}, {0, 0, 1}}).value();
    EXPECT_FALSE(miss.objects[0].triangle->same_direction);
    EXPECT_FALSE(miss.objects[0].hit);
    EXPECT_FALSE(miss.first_hit);

    Explanation parallel = explain(s, Ray{{0, 0, 0}, {1, 0, 0}}).value();
    EXPECT_FALSE(parallel.objects[0].hit);
    EXPECT_FALSE(parallel.objects[0].triangle->t);
}

/// Whether a step writes a number as "inf" or "nan" (as words: "discriminant" is fine).
bool has_inf_or_nan(const std::vector<std::string>& steps) {
    const std::regex inf_or_nan(R"(\b(inf|nan)\b)");
    for (const std::string& step : steps) {
        if (std::regex_search(step, inf_or_nan))
            return true;
    }
    return false;
}

// Coordinates whose products leave double's range: the quadratic's A, B, C (past ~1e154) and
// the plane's ⟨n,a⟩ (past ~1e102) had been written out as "inf" and "nan" (2e200t + nan = 0).
// They are not written; the roots and the hit are the engine's rescaled kernels', right.
TEST(Explain, ProductsBeyondDoublesRangeAreNotWrittenOut) {
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(testing::sphere("far", {0, 0, 0}, 1e199, 0));
    s.objects.push_back(testing::mesh_object(
        "huge", {{-1e120, -1e120, 3e200}, {4e120, -1e120, 3e200}, {-1e120, 4e120, 3e200}},
        {{0, 1, 2}}));
    const Explanation ex = explain(s, Ray{{0, 0, -1e200}, {0, 0, 1}}).value();
    const ObjectWork& sphere = ex.objects[0];
    ASSERT_TRUE(sphere.sphere);
    EXPECT_FALSE(sphere.sphere->representable);
    EXPECT_FALSE(has_inf_or_nan(sphere.steps));
    ASSERT_EQ(sphere.sphere->roots.size(), 2u);
    EXPECT_EQ(sphere.sphere->roots[0], 9e199);
    EXPECT_EQ(sphere.sphere->roots[1], 1.1e200);
    EXPECT_TRUE(sphere.hit);

    const ObjectWork& tri = ex.objects[1];
    ASSERT_TRUE(tri.triangle);
    EXPECT_FALSE(tri.triangle->representable);
    EXPECT_FALSE(has_inf_or_nan(tri.steps));
    ASSERT_TRUE(tri.hit);
    EXPECT_EQ(*tri.t, 4e200);
    EXPECT_EQ(*tri.triangle->point, (Vec3d{0, 0, 3e200}));
    ASSERT_TRUE(ex.first_hit);
    EXPECT_EQ(ex.first_hit->object, 0u);

    // A miss at that scale is the watertight test's too.
    const Explanation miss = explain(s, Ray{{1e121, 0, -1e200}, {0, 0, 1}}).value();
    EXPECT_FALSE(miss.objects[1].hit);
    EXPECT_EQ(miss.objects[1].reason, "the watertight test: the ray misses");

    // Edges below ~1e-150 underflow n = ac × ab to zero, which read as a degenerate triangle.
    Scene tiny;
    tiny.materials.push_back(Material{});
    tiny.objects.push_back(
        testing::mesh_object("tiny", {{0, 0, 1}, {2e-160, 0, 1}, {0, 2e-160, 1}}, {{0, 1, 2}}));
    const Explanation small = explain(tiny, Ray{{5e-161, 5e-161, 0}, {0, 0, 1}}).value();
    EXPECT_FALSE(small.objects[0].triangle->representable);
    EXPECT_TRUE(small.objects[0].hit);
    EXPECT_EQ(*small.objects[0].t, 1.0);

    // t past double's range (a direction 1e-150 long from 1e200 away), and cross products that
    // overflow at a point 1e160 out (a helper's review: "t = inf", "d = (-nan, ...)").
    Scene unit;
    unit.materials.push_back(Material{});
    unit.objects.push_back(
        testing::mesh_object("abc", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}));
    unit.objects.push_back(testing::sphere("ball", {0, 0, -5}, 1.0, 0));
    const Explanation beyond = explain(unit, Ray{{0.2, 0.2, 1e200}, {0, 0, -1e-150}}).value();
    for (const ObjectWork& w : beyond.objects) {
        EXPECT_FALSE(has_inf_or_nan(w.steps)) << w.name;
        EXPECT_FALSE(w.hit) << w.name;
    }
    EXPECT_FALSE(beyond.first_hit);
    Scene wide;
    wide.materials.push_back(Material{});
    wide.objects.push_back(
        testing::mesh_object("wide", {{0, 0, 0}, {2e160, 0, 0}, {0, 2e160, 0}}, {{0, 1, 2}}));
    const Explanation crossed = explain(wide, Ray{{1e160, 1e159, 1}, {0, 0, -1}}).value();
    EXPECT_FALSE(has_inf_or_nan(crossed.objects[0].steps));
    EXPECT_FALSE(crossed.objects[0].triangle->representable);
    ASSERT_TRUE(crossed.objects[0].hit);
    EXPECT_EQ(*crossed.objects[0].t, 1.0);
    const Explanation aside = explain(unit, Ray{{1e160, 1e160, 1}, {0, 0, -1}}).value();
    EXPECT_FALSE(has_inf_or_nan(aside.objects[0].steps));
    EXPECT_FALSE(aside.objects[0].hit);

    // Ordinary coordinates keep the tutorial's algebra.
    const Explanation near =
        explain(testing::tutorial_spheres(), Ray{{0, 0, 0}, {0, 0, 1}}).value();
    EXPECT_TRUE(near.objects[0].sphere->representable);
}

// A sphere of radius 1e-300, 5 away, on the line: its discriminant, 4e-600, underflowed and was
// written "discriminant B^2-4AC = 0" above "no real roots: the ray misses", which contradict each
// other. The engine takes it as missed because it lies below double's resolution there
// (SphereRoots::unresolved), and the solution now says that; one of radius 1e-170, which the
// kernel scales up and hits, has its underflowed discriminant left out instead.
TEST(Explain, ASphereBelowDoublesResolutionSaysWhyItIsMissed) {
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(testing::sphere("speck", {0, 0, 5}, 1e-300, 0));
    s.objects.push_back(testing::sphere("grain", {0, 0, 9}, 1e-170, 0));
    const Explanation ex = explain(s, Ray{{0, 0, 0}, {0, 0, 1}}).value();
    const ObjectWork& speck = ex.objects[0];
    EXPECT_FALSE(speck.hit);
    EXPECT_NE(speck.reason.find("below 2^-900 of its distance"), std::string::npos) << speck.reason;
    EXPECT_FALSE(speck.sphere->representable);
    for (const std::string& step : speck.steps)
        EXPECT_EQ(step.find("discriminant"), std::string::npos) << step;
    const ObjectWork& grain = ex.objects[1];
    EXPECT_TRUE(grain.hit);
    EXPECT_EQ(*grain.t, 9.0);
    EXPECT_FALSE(grain.sphere->representable);
    ASSERT_TRUE(ex.first_hit);
    EXPECT_EQ(ex.first_hit->object, 1u);
    // The intersectors agree: the speck is missed, the grain hit.
    const auto engine = QueryEngine::build(std::make_shared<const Scene>(s));
    ASSERT_TRUE(engine.ok());
    const auto hit = (*engine)->closest(Ray{{0, 0, 0}, {0, 0, 1}}, Precision::exact, false);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->object, 1u);
}

TEST(Explain, ARootPastTheLargestDoubleLeavesTheOther) {
    // From inside a sphere 2e300 across, halfway up, with a direction 4e-9 long: the root behind
    // is -1.5e300 / 4e-9, past the largest double, and the one ahead 1.25e308, which is what the
    // intersectors answer. The overflowing root had taken the finite one with it ("no hit").
    Scene scene;
    scene.materials.push_back(Material{});
    scene.material_names.push_back("default");
    scene.objects.push_back(testing::sphere("huge", {0, 0, 0}, 1e300, 0));
    const Ray ray{{0, 0, 0.5e300}, {0, 0, 4e-9}};
    const Explanation ex = explain(scene, ray).value();
    const ObjectWork& w = ex.objects[0];
    ASSERT_TRUE(w.sphere);
    ASSERT_EQ(w.sphere->roots.size(), 1u);
    EXPECT_NEAR(w.sphere->roots[0], 1.25e308, 1e293);
    EXPECT_FALSE(has_inf_or_nan(w.steps));
    ASSERT_TRUE(w.hit);
    EXPECT_EQ(*w.t, w.sphere->roots[0]);
    ASSERT_TRUE(ex.first_hit);
    EXPECT_EQ(ex.first_hit->t, *w.t);

    Ray short_ray = ray;
    short_ray.tmax = 1e308;
    const Explanation before = explain(scene, short_ray).value();
    EXPECT_FALSE(before.objects[0].hit);
    EXPECT_EQ(before.objects[0].reason,
              "the finite root lies outside [tmin, tmax]: the ray misses");
    EXPECT_FALSE(before.first_hit);
}

TEST(Explain, StopsWhenItsTokenHasFired) {
    const CancelToken stopped = CancelToken::make();
    stopped.cancel();
    const auto ex = explain(testing::tutorial_spheres(), Ray{{0, 0, 0}, {0, 0, 1}}, stopped);
    ASSERT_FALSE(ex.ok());
    EXPECT_EQ(ex.status().code, Code::cancelled);
}

}  // namespace
}  // namespace raycastd::engine
