#include "engine/shade/phong.h"

#include <cmath>

#include <gtest/gtest.h>

#include "engine/math/float_bounds.h"
#include "engine/shade/optics.h"

namespace raycastd::engine {
namespace {

TEST(Phong, DiffuseIsLambertAndSpecularPeaksOnTheMirrorDirection) {
    Material m;
    m.diffuse = {0.5, 0.5, 0.5};
    m.specular = {1, 1, 1};
    m.shininess = 10;
    const Vec3d n{0, 0, 1};
    const Vec3d l = normalize(Vec3d{1, 0, 1});
    // The viewer exactly on the mirror direction: R·V = 1, so the specular term is ks·Ip.
    const Vec3d v = normalize(Vec3d{-1, 0, 1});
    const PhongLightTerms t = phong_light(m, n, l, v, {2, 2, 2}, true);
    EXPECT_NEAR(t.diffuse.x, 2 * 0.5 * std::sqrt(0.5), 1e-15);
    EXPECT_NEAR(t.specular.x, 2.0, 1e-12);
    // Off the mirror direction by 45°: (R·V)^10 = (√½)^10 = 1/32.
    const PhongLightTerms t2 = phong_light(m, n, l, {0, 0, 1}, {1, 1, 1}, true);
    EXPECT_NEAR(t2.specular.x, 1.0 / 32, 1e-12);
}

TEST(Phong, LightBehindTheSurfaceAddsNothing) {
    Material m;
    const PhongLightTerms t = phong_light(m, {0, 0, 1}, {0, 0, -1}, {0, 0, 1}, {1, 1, 1}, true);
    EXPECT_EQ(t.sum(), Vec3d{});
    const PhongLightTerms grazing =
        phong_light(m, {0, 0, 1}, {1, 0, 0}, {0, 0, 1}, {1, 1, 1}, true);
    EXPECT_EQ(grazing.sum(), Vec3d{});
}

TEST(Phong, SpecularCanBeSkipped) {
    Material m;
    const PhongLightTerms t = phong_light(m, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {1, 1, 1}, false);
    EXPECT_EQ(t.specular, Vec3d{});
    EXPECT_GT(t.diffuse.x, 0.0);
}

TEST(Phong, AmbientIsKaTimesIaPerChannel) {
    // The textured ka of a surface (its material's ambient times the texture's colour) times
    // the ambient intensity, channel by channel.
    EXPECT_EQ(phong_ambient({0.1, 0.5, 1.0}, {0.5, 0.25, 2.0}), Vec3d(0.05, 0.125, 2.0));
    EXPECT_EQ(phong_ambient({0.3, 0.3, 0.3}, {}), Vec3d{});
}

// Whole exponents up to 1024 by repeated squaring, within 2n·u of std::pow over the cosines a
// highlight takes; others are std::pow's own.
TEST(Phong, PowerOfAWholeShininessIsPowsWithinRounding) {
    for (double n : {0.0, 1.0, 2.0, 3.0, 30.0, 200.0, 300.0, 1000.0, 1024.0}) {
        for (double x : {1.0, 0.999999, 0.99, 0.9, 0.7, 0.5, 0.25, 1e-3}) {
            const double want = std::pow(x, n);
            EXPECT_NEAR(phong_power(x, n), want, (2.0 * n + 2.0) * kDoubleUnitRoundoff * want)
                << x << "^" << n;
        }
    }
    EXPECT_EQ(phong_power(0.5, 6.33), std::pow(0.5, 6.33));
    EXPECT_EQ(phong_power(0.9, 1025.0), std::pow(0.9, 1025.0));
    EXPECT_EQ(phong_power(0.0, 0.0), 1.0);
}

TEST(Optics, ReflectionMirrorsAboutTheNormal) {
    EXPECT_EQ(reflect({1, -1, 0}, {0, 1, 0}), Vec3d(1, 1, 0));
    EXPECT_EQ(reflect({1, -1, 0}, {0, -1, 0}), Vec3d(1, 1, 0));  // either side of the normal
}

TEST(Optics, SnellBendsTowardsTheNormalEnteringGlass) {
    // 45° from air into glass (η = 1/1.5): sin θ₂ = sin 45° / 1.5.
    const Vec3d d = normalize(Vec3d{1, -1, 0});
    const auto t = refract(d, {0, 1, 0}, 1.0 / 1.5);
    ASSERT_TRUE(t);
    EXPECT_NEAR(t->x, std::sqrt(0.5) / 1.5, 1e-15);
    EXPECT_NEAR(length(*t), 1.0, 1e-15);
    EXPECT_LT(t->y, 0.0);
    // Normal incidence goes straight through.
    const auto straight = refract({0, 0, 1}, {0, 0, -1}, 1.0 / 1.5);
    ASSERT_TRUE(straight);
    EXPECT_NEAR(straight->z, 1.0, 1e-15);
}

TEST(Optics, TotalInternalReflectionPastTheCriticalAngle) {
    // Leaving glass (η = 1.5): the critical angle is asin(1/1.5) ≈ 41.8°; 45° is past it.
    EXPECT_FALSE(refract(normalize(Vec3d{1, -1, 0}), {0, 1, 0}, 1.5));
    EXPECT_TRUE(refract(normalize(Vec3d{0.5, -1, 0}), {0, 1, 0}, 1.5));
}

}  // namespace
}  // namespace raycastd::engine
