// fast's packet lanes (packets.h): filled four at a time in AVX's registers they are the lanes
// filled one ray at a time, bit for bit, with the same coherence flag and the same refusals.

#include "engine/accel/embree/packets.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace raycastd::engine::embree {
namespace {

struct Filled {
    bool ok = false;
    RTCRay16 r16;
    int valid[kLanes];
    RTCIntersectContextFlags flags = RTC_INTERSECT_CONTEXT_FLAG_NONE;
};

Filled fill(const Impl& a, const std::vector<Ray>& rays, FastLanes how, unsigned char junk) {
    Filled f;
    // Junk in every byte first: a field one way leaves unwritten shows as a difference.
    std::memset(&f.r16, junk, sizeof f.r16);
    std::memset(f.valid, junk, sizeof f.valid);
    const std::optional<RTCIntersectContext> ctx =
        fill_fast_lanes(a, rays.data(), rays.size(), f.r16, f.valid, how);
    f.ok = ctx.has_value();
    if (ctx)
        f.flags = ctx->flags;
    return f;
}

void expect_same_lanes(const Impl& a, const std::vector<Ray>& rays, const char* what) {
    const Filled one = fill(a, rays, FastLanes::one_by_one, 0x5A);
    const Filled avx = fill(a, rays, FastLanes::avx, 0xA5);
    ASSERT_EQ(one.ok, avx.ok) << what;
    if (!one.ok)
        return;
    EXPECT_EQ(std::memcmp(&one.r16, &avx.r16, sizeof one.r16), 0) << what;
    EXPECT_EQ(std::memcmp(one.valid, avx.valid, sizeof one.valid), 0) << what;
    EXPECT_EQ(one.flags, avx.flags) << what;
}

TEST(FastLanes, AvxFillsTheLanesOneByOneFills) {
    if (widest_fast_lanes() != FastLanes::avx)
        GTEST_SKIP() << "this processor has no AVX: only the one-by-one lanes run here";
    Impl a;
    a.center = {0.3, -1.2, 5.0};
    a.unit = 0.25;  // a scene 4–8 across
    a.float_scale = 5.0;
    std::mt19937_64 rng(17);
    std::uniform_real_distribution<double> in(-19.0, 19.0), unit(-1.0, 1.0), expo(-5.0, 5.0);
    const auto random_ray = [&] {
        Ray r;
        r.origin = a.center + Vec3d{in(rng), in(rng), in(rng)};
        r.direction = Vec3d{unit(rng), unit(rng), unit(rng)} * std::pow(10.0, expo(rng));
        r.tmin = rng() % 2 ? 0.0 : std::abs(in(rng));
        r.tmax = rng() % 3 ? kInfinity : r.tmin + std::abs(in(rng));
        return r;
    };
    int coherent = 0, incoherent = 0;
    for (int round = 0; round < 400; ++round) {
        const std::size_t m = 4 + round % 13;
        std::vector<Ray> rays(m);
        if (round % 2) {
            // Camera-like: one origin, directions within a few degrees.
            const Vec3d o = a.center + Vec3d{0, 0, -15.0};
            for (Ray& r : rays) {
                r.origin = o;
                r.direction = Vec3d{0.02 * unit(rng), 0.02 * unit(rng), 1.0};
            }
        } else {
            for (Ray& r : rays)
                r = random_ray();
        }
        if (round % 7 == 3)
            rays[rng() % m].tmax = 1e300;  // past float's range: +inf in both
        if (round % 11 == 5)
            rays[rng() % m].tmax = std::numeric_limits<float>::max() / a.unit * (1 + 1e-12);
        expect_same_lanes(a, rays, "ordinary rays");
        const Filled f = fill(a, rays, FastLanes::avx, 0);
        ASSERT_TRUE(f.ok);
        (f.flags == RTC_INTERSECT_CONTEXT_FLAG_COHERENT ? coherent : incoherent) += 1;
    }
    EXPECT_EQ(coherent, 200);  // the camera-like rounds, and no random one
    EXPECT_EQ(incoherent, 200);

    // One stray ray among camera rays, in each lane: the packet is incoherent both ways.
    for (std::size_t stray = 1; stray < kLanes; ++stray) {
        std::vector<Ray> rays(kLanes);
        for (Ray& r : rays) {
            r.origin = a.center + Vec3d{0, 0, -15.0};
            r.direction = Vec3d{0.01, -0.01, 1.0};
        }
        rays[stray].direction = Vec3d{0.5, 0.0, 1.0};  // 27° off
        expect_same_lanes(a, rays, "a stray direction");
        EXPECT_EQ(fill(a, rays, FastLanes::avx, 0).flags, RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
        rays[stray].direction = rays[0].direction;
        rays[stray].origin.x += 2.0;  // 10% of the scene away
        expect_same_lanes(a, rays, "a stray origin");
        EXPECT_EQ(fill(a, rays, FastLanes::avx, 0).flags, RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
    }

    // A ray either way refuses the whole packet (prepare_ray then sets it up), wherever it is.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    for (int which = 0; which < 6; ++which) {
        for (std::size_t at : {0u, 3u, 4u, 9u}) {
            std::vector<Ray> rays(10);
            for (Ray& r : rays)
                r = random_ray();
            Ray& r = rays[at];
            switch (which) {
                case 0:
                    r.origin.x = a.center.x + 21.0;
                    break;  // beyond 4 scene sizes
                case 1:
                    r.origin.z = a.center.z - 20.5;
                    break;
                case 2:
                    r.tmin = -1.0;
                    break;
                case 3:
                    r.direction = Vec3d{1e-7, 0, 0};
                    break;  // |d|² below 1e-12
                case 4:
                    r.direction = Vec3d{0, 2e6, 0};
                    break;  // |d|² above 1e12
                case 5:
                    r.origin.y = nan;
                    break;
            }
            EXPECT_FALSE(fill(a, rays, FastLanes::one_by_one, 0).ok) << which << " at " << at;
            EXPECT_FALSE(fill(a, rays, FastLanes::avx, 0).ok) << which << " at " << at;
        }
    }
}

}  // namespace
}  // namespace raycastd::engine::embree
