// clip_to_bounds (float_ray.h): its branch-free ordering of the slab distances (2026-12-06) gives
// the segment the swap it replaced gave, bit for bit, on random rays and on the cases where a
// slab distance is NaN or infinite (a subnormal direction component: 1/d overflows, and an
// origin on the slab's plane makes 0·∞).

#include "engine/accel/embree/float_ray.h"

#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "engine/testing/bits.h"

namespace raycastd::engine::embree {
namespace {

/// The slab test as it was written until 2026-12-06: the two distances swapped when out of
/// order. The reference the branch-free form must reproduce.
bool clip_with_swap(const Bounds3& bounds, const Ray& ray, double& t0, double& t1) {
    t0 = ray.tmin;
    t1 = ray.tmax;
    for (std::size_t k = 0; k < 3; ++k) {
        const double o = ray.origin[k], d = ray.direction[k];
        const double lo = bounds.lo[k], hi = bounds.hi[k];
        if (d == 0.0) {
            if (o < lo || o > hi)
                return false;
            continue;
        }
        const double inv = 1.0 / d;
        double ta = (lo - o) * inv, tb = (hi - o) * inv;
        if (ta > tb)
            std::swap(ta, tb);
        t0 = std::max(t0, ta - gamma(3) * std::abs(ta));
        t1 = std::min(t1, tb + gamma(3) * std::abs(tb));
    }
    return t0 <= t1;
}

using testing::same_bits;

TEST(FloatRay, ClipToBoundsOrdersTheSlabsAsTheSwapDid) {
    Bounds3 box;
    box.lo = Vec3d{-1.0, -2.0, 0.5};
    box.hi = Vec3d{3.0, 1.0, 4.0};
    std::mt19937_64 rng(20261206);
    std::uniform_real_distribution<double> coord(-6.0, 6.0);
    std::vector<Ray> rays;
    for (int i = 0; i < 20000; ++i) {
        Ray r;
        r.origin = Vec3d{coord(rng), coord(rng), coord(rng)};
        r.direction = Vec3d{coord(rng), coord(rng), coord(rng)};
        r.tmin = (i % 3 == 0) ? 0.5 : 0.0;
        r.tmax = (i % 5 == 0) ? 2.0 : std::numeric_limits<double>::infinity();
        rays.push_back(r);
    }
    // Distances that are NaN or infinite: a subnormal component (1/d = ±∞) from an origin on
    // the slab's lower or upper plane (0·∞ = NaN) and off it (±∞); a zero component inside and
    // outside the slab. (The widening then makes an infinite distance NaN too, which the
    // std::max and std::min of the range ignore: a form that let such a slab cut the range
    // would show here.)
    const double tiny = std::numeric_limits<double>::denorm_min();
    for (const double o : {-1.0, 3.0, 0.0, -5.0, 7.0}) {
        for (const double d : {tiny, -tiny, 0.0, 1e-310, -3e-320}) {
            Ray r;
            r.origin = Vec3d{o, 0.0, 1.0};
            r.direction = Vec3d{d, 0.5, 1.0};
            rays.push_back(r);
            r.origin = Vec3d{0.0, 0.0, o};
            r.direction = Vec3d{1.0, -0.25, d};
            rays.push_back(r);
        }
    }
    int met = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        double a0 = -7.0, a1 = -7.0, b0 = -7.0, b1 = -7.0;
        const bool a = clip_to_bounds(box, rays[i], a0, a1);
        const bool b = clip_with_swap(box, rays[i], b0, b1);
        ASSERT_EQ(a, b) << i;
        met += a;
        if (a) {
            EXPECT_TRUE(same_bits(a0, b0)) << i << ": " << a0 << " against " << b0;
            EXPECT_TRUE(same_bits(a1, b1)) << i << ": " << a1 << " against " << b1;
        }
    }
    // Both outcomes are exercised.
    EXPECT_GT(met, 1000);
    EXPECT_LT(met, static_cast<int>(rays.size()) - 1000);
}

}  // namespace
}  // namespace raycastd::engine::embree
