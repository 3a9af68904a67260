// Expansion and triple_product_sign (exact_sign.h): exact where double and long double round to
// the wrong answer.

#include "engine/math/exact_sign.h"

#include <cmath>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

TEST(ExactSign, ExpansionSumsExactly) {
    Expansion e;
    EXPECT_EQ(e.sign(), 0);
    // 1e100 + 1 − 1e100: double loses the 1.
    e.add(1e100);
    e.add(1.0);
    e.add(-1e100);
    EXPECT_EQ(e.sign(), 1);
    e.add(-1.0);
    EXPECT_EQ(e.sign(), 0);
    // Many terms that cancel but for the smallest.
    Expansion f;
    for (int k = 0; k < 40; ++k) {
        f.add(std::ldexp(1.0, 20 * k - 400));
        f.add(-std::ldexp(3.0, 20 * k - 402));  // −3/4 of it
    }
    for (int k = 0; k < 40; ++k)
        f.add(-std::ldexp(1.0, 20 * k - 402));  // the remaining 1/4
    f.add(-0x1p-1000);
    EXPECT_EQ(f.sign(), -1);
}

// ((p − o) × (q − o))·d with d = +z is p_x q_y − p_y q_x: at 2^40 the products need 80 bits,
// more than double's 53 or long double's 64, and both round the difference to 0.
TEST(ExactSign, TripleProductWhereProductsNeedEightyBits) {
    const double big = 0x1p40;
    const Vec3d o{0, 0, -1}, d{0, 0, 1};
    const Vec3d p{big, big + 1, 0}, q{-(big - 1), -big, 0};
    // p_x q_y − p_y q_x = −2^80 + (2^80 − 1) = −1.
    using LD = long double;
    EXPECT_EQ(LD(p.x) * LD(q.y) - LD(p.y) * LD(q.x), 0.0L);
    bool exact = false;
    EXPECT_EQ(triple_product_sign(p, q, o, d, exact), -1);
    EXPECT_TRUE(exact);
    EXPECT_EQ(triple_product_sign(q, p, o, d, exact), 1);  // antisymmetric
    EXPECT_EQ(triple_product_sign(p, q, o, Vec3d{0, 0, -1}, exact), 1);
    // Collinear with the origin: 0.
    EXPECT_EQ(triple_product_sign({2, 4, 6}, {1, 2, 3}, {0, 0, 0}, {0.3, -1, 7}, exact), 0);
    // An origin off the world origin: the differences are formed exactly too.
    EXPECT_EQ(triple_product_sign(p + Vec3d{0.5, 0.5, 0}, q + Vec3d{0.5, 0.5, 0},
                                  o + Vec3d{0.5, 0.5, 0}, d, exact),
              -1);
    // Products near underflow cannot be formed exactly, and say so.
    triple_product_sign({1e-300, 0, 0}, {0, 1e-300, 0}, {0, 0, 0}, {0, 0, 1e-300}, exact);
    EXPECT_FALSE(exact);
}

}  // namespace
}  // namespace raycastd::engine
