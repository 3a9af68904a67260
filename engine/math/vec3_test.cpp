#include "engine/math/vec3.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

// normalize() gives a unit vector where |v|² overflows or underflows (a triangle 1e78 across had
// the normal (0, 0, 0), one 1e-170 across its cross product unnormalised), and divides ordinary
// vectors as before, bit for bit; zero and non-finite vectors stay as they were.
TEST(Vec3, NormalizeGivesUnitVectorsAtEveryScale) {
    for (const double scale : {1e-300, 1e-170, 1e-155, 1.0, 1e150, 1e160, 1e300}) {
        const Vec3d v = Vec3d{3, -4, 12} * scale;
        const Vec3d n = normalize(v);
        EXPECT_NEAR(n.x, 3.0 / 13.0, 1e-15) << scale;
        EXPECT_NEAR(n.y, -4.0 / 13.0, 1e-15) << scale;
        EXPECT_NEAR(n.z, 12.0 / 13.0, 1e-15) << scale;
    }
    const Vec3d plain{0.3, -0.7, 2.5};
    EXPECT_EQ(normalize(plain), plain / std::sqrt(dot(plain, plain)));
    EXPECT_EQ(normalize(Vec3d{0, 0, 0}), Vec3d(0, 0, 0));
    EXPECT_TRUE(std::isnan(normalize(Vec3d{std::nan(""), 1, 0}).x));
    const Vec3f f = normalize(Vec3f{3e25f, -4e25f, 12e25f});
    EXPECT_NEAR(f.z, 12.0f / 13.0f, 1e-6f);
}

}  // namespace
}  // namespace raycastd::engine
