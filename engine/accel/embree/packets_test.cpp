// fast's packets (packets.h): lanes filled four at a time in AVX's registers are the lanes
// filled one ray at a time, bit for bit, with the same coherence flag and the same refusals; and
// answers made four lanes at a time are the Hits fast_hit makes lane by lane. refined's lanes
// set up four at a time are prepare_ray's, lane by lane, context and float ray alike. And
// packet_context flags a packet as coherent() of the whole packet says.

#include "engine/accel/embree/packets.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "engine/accel/embree/float_ray.h"
#include "engine/math/float_bounds.h"
#include "engine/testing/bits.h"

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
        if (round % 17 == 8)
            rays[rng() % m].tmax = -1e300;  // an empty range, below float's: −inf in both
        if (round % 19 == 9)
            rays[rng() % m].tmax = -std::numeric_limits<float>::max() / a.unit * (1 + 1e-12);
        if (round % 23 == 10)  // exactly ±FLT_MAX in the frame (unit is a power of two): kept
            rays[rng() % m].tmax =
                (round % 2 ? 1.0 : -1.0) * std::numeric_limits<float>::max() / a.unit;
        if (round % 29 == 11)  // NaN: neither beyond, left as it is
            rays[rng() % m].tmax = std::numeric_limits<double>::quiet_NaN();
        if (round % 13 == 6) {  // tnear past float's range too
            Ray& r = rays[rng() % m];
            r.tmin = std::numeric_limits<float>::max() / a.unit * (1 + 1e-12);
            r.tmax = kInfinity;
        }
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

using testing::same_bits;

TEST(FastLanes, AvxAnswersAsOneByOne) {
    if (widest_fast_lanes() != FastLanes::avx)
        GTEST_SKIP() << "this processor has no AVX: only the one-by-one answers run here";
    Impl a;
    a.center = {-2.0, 0.5, 1e3};
    a.unit = 0x1p-3;
    a.float_scale = 7.0;
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> in(-20.0, 20.0), unit(-1.0, 1.0), expo(-4.0, 4.0);
    std::uniform_real_distribution<float> tf(0.0f, 30.0f), bary(0.0f, 1.0f), ng(-3.0f, 3.0f);
    int hits = 0, misses = 0, clamped = 0, zero_segments = 0;
    for (int round = 0; round < 300; ++round) {
        const std::size_t m = 4 + round % 13;
        std::vector<Ray> rays(m);
        alignas(64) RTCRayHit16 rh;
        std::memset(&rh, 0, sizeof rh);
        for (std::size_t k = 0; k < kLanes; ++k) {
            Ray& r = rays[std::min(k, m - 1)];
            if (k < m) {
                r.origin = a.center + Vec3d{in(rng), in(rng), in(rng)};
                r.direction = Vec3d{unit(rng), unit(rng), unit(rng)} * std::pow(10.0, expo(rng));
                r.tmin = rng() % 2 ? 0.0 : 0.5;
                r.tmax = rng() % 2 ? kInfinity : 2.0;
            }
            rh.ray.tfar[k] = tf(rng);
            if (k < m && rng() % 11 == 0) {
                // A segment [0, −0]: t is +0 as std::min(+0, −0) gives it (min_pd with its
                // operands the other way round would give −0).
                r.tmin = 0.0;
                r.tmax = -0.0;
                rh.ray.tfar[k] = 0.0f;
            }
            rh.hit.u[k] = bary(rng);
            rh.hit.v[k] = bary(rng);
            // Now and then a zero normal (the zero vector is answered) or a miss.
            const bool flat = rng() % 17 == 0;
            rh.hit.Ng_x[k] = flat ? 0.0f : ng(rng);
            rh.hit.Ng_y[k] = flat ? 0.0f : ng(rng);
            rh.hit.Ng_z[k] = flat ? 0.0f : ng(rng);
            rh.hit.geomID[k] = rng() % 5 == 0 ? RTC_INVALID_GEOMETRY_ID : 3u;
            rh.hit.primID[k] = static_cast<unsigned>(rng() % 1000);
        }
        for (const bool normals : {false, true}) {
            std::vector<Hit> one(m), avx(m);
            for (std::size_t k = 0; k < m; ++k)  // junk the answers must overwrite
                one[k].t = avx[k].t = -7.0, one[k].on_edge = avx[k].on_edge = true;
            fast_packet_answers(a, rays.data(), m, rh, normals, one.data(), FastLanes::one_by_one);
            fast_packet_answers(a, rays.data(), m, rh, normals, avx.data(), FastLanes::avx);
            for (std::size_t k = 0; k < m; ++k) {
                const Hit& x = one[k];
                const Hit& y = avx[k];
                EXPECT_TRUE(testing::same_hit(x, y))
                    << "round " << round << " lane " << k << ": t " << x.t << " / " << y.t;
                (x.valid() ? hits : misses) += 1;
                clamped += x.valid() && (x.t == rays[k].tmin || x.t == rays[k].tmax);
                zero_segments += x.valid() && std::signbit(rays[k].tmax);
            }
        }
    }
    EXPECT_GT(hits, 3000);  // both kinds of lane, and t clamped at both ends, were compared
    EXPECT_GT(misses, 500);
    EXPECT_GT(clamped, 500);
    EXPECT_GT(zero_segments, 50);
}

/// refined's lanes of `rays` (fill_backed_off_lanes), each lane's context and the packet, with
/// junk in every byte first (a field one way leaves unwritten shows as a difference).
struct BackedOffLanes {
    RayContext lanes[kLanes];
    RTCRay16 r16;
    int valid[kLanes];
};

void fill_refined(const Impl& a, const std::vector<Ray>& rays, bool want_normal, FastLanes how,
                  unsigned char junk, BackedOffLanes& out) {
    std::memset(&out.r16, junk, sizeof out.r16);
    std::memset(out.valid, junk, sizeof out.valid);
    for (RayContext& c : out.lanes) {
        c = RayContext{};
        c.ray = nullptr;
        c.shift = c.len = c.margin = c.origin_err = -7.0;
        c.far = true;
    }
    const auto prepare = [&](const Ray& ray, RayContext& c, FloatRay& f) {
        c.want_normal = want_normal;  // as prepare_refined_closest_ray
        return prepare_ray(a, ray, RayStart::backed_off, c, f);
    };
    fill_backed_off_lanes(a, rays.data(), rays.size(), want_normal, prepare, out.lanes, out.r16,
                          out.valid, how);
}

TEST(BackedOffLanes, AvxSetsUpTheLanesPrepareRaySetsUp) {
    if (widest_fast_lanes() != FastLanes::avx)
        GTEST_SKIP() << "this processor has no AVX: only prepare_ray's lanes run here";
    const double nan = std::numeric_limits<double>::quiet_NaN();
    // Scenes of ordinary size, 2^±1000 across, and 1e12 from the origin: prepare_ray's checks on
    // the length and the start point (len over- and underflowing, margin/len, the reach) bite
    // only at the extremes (a helper's review: with `len < inf` deleted, a scene 2^-1001 across
    // and a direction 2^400 long went through AVX with len = +inf).
    struct Frame {
        Vec3d centre;
        double size;
    };
    const Frame frames[] = {{{0.5, 2.125, 4.25}, 1.0},
                            {{0.3, -0.2, 0.1}, 0x1p-1002},
                            {{-3.0, 1.0, 2.0}, 0x1p999},
                            {{1e12, -2e12, 5e11}, 1.0}};
    std::mt19937_64 rng(23);
    std::uniform_real_distribution<double> in(-12.0, 12.0), unit(-1.0, 1.0), expo(-3.0, 3.0);
    // What each lane was: set up by AVX (on), off (its segment misses the bounds), or another
    // branch of prepare_ray; each must come out as prepare_ray makes it.
    int on = 0, off = 0, special = 0, by_avx = 0;
    for (const Frame& frame : frames) {
        Impl a;
        const Vec3d half = Vec3d{2.0, 1.875, 1.25} * frame.size;
        a.set_frame(Bounds3{frame.centre - half, frame.centre + half});
        const Vec3d c = a.center;
        const double s = frame.size;
        for (int round = 0; round < 200; ++round) {
            const std::size_t m = 4 + round % 13;
            std::vector<Ray> rays(m);
            for (Ray& r : rays) {
                r.origin = c + Vec3d{in(rng), in(rng), in(rng)} * s;
                // Aimed near the scene three times in four (most of those meet the bounds).
                const Vec3d target = c + Vec3d{unit(rng), unit(rng), unit(rng)} * (2.0 * s);
                r.direction = rng() % 4 ? (target - r.origin) * (std::pow(10.0, expo(rng)) / s)
                                        : Vec3d{unit(rng), unit(rng), unit(rng)};
                r.tmin = rng() % 3 == 0 ? 0.5 : 0.0;
                r.tmax = rng() % 2 ? kInfinity : std::pow(10.0, expo(rng));
                switch (rng() % 32) {  // now and then an edge of prepare_ray's arithmetic
                    case 0:
                        r.direction.x = 0.0;
                        break;
                    case 1:
                        r.direction.z = -0.0;
                        break;
                    case 2:
                        r.direction.y = nan;
                        break;
                    case 3:
                        r.direction = r.direction * 0x1p-520;  // |d| below 2^-500
                        break;
                    case 4:
                        r.direction = r.direction * 0x1p520;
                        break;
                    case 5:
                        r.direction = r.direction * 0x1p400;  // len overflows in a tiny scene
                        break;
                    case 6:
                        r.direction = r.direction * 0x1p-400;
                        break;
                    case 7:
                        r.origin = c + (c - target) * 1e9;  // the double-double start point
                        r.direction = target - r.origin;
                        break;
                    case 8:
                        r.origin = c + (c - target) * 1e18;  // left unplaced
                        r.direction = target - r.origin;
                        break;
                    case 9:
                        r.tmin = 3.0;
                        r.tmax = 1.0;  // an empty segment
                        break;
                    case 10:
                        r.origin.x = nan;
                        break;
                    case 11:
                        r.tmax = -0.0;
                        break;
                    case 12:
                        r.tmin = -1.0;
                        break;
                    case 13:
                        r.tmin = -kInfinity;
                        break;
                    case 14:
                        r.tmin = nan;
                        break;
                    case 15:
                        r.tmax = nan;
                        break;
                    case 16:
                        r.tmax = -kInfinity;
                        break;
                    case 17:
                        r.origin.y = a.padded_bounds.lo.y;  // on the padded bounds
                        break;
                    case 18:
                        r.origin.z = a.padded_bounds.hi.z;
                        break;
                    case 19:
                        // From the centre, 2^30 long: in the tiny scene len = |d|·unit
                        // overflows while the backing off, 4·pad/|d|, does not underflow.
                        r.origin = c;
                        r.direction = Vec3d{1.0, 1.06, -1.19} * 0x1p30;
                        break;
                    default:
                        break;
                }
            }
            {
                // How many lanes AVX set up itself (the rest went to prepare_ray).
                BackedOffLanes x;
                const unsigned left =
                    backed_off_lanes_avx(a, rays.data(), m, false, x.lanes, x.r16, x.valid);
                by_avx += static_cast<int>(m) - __builtin_popcount(left & ((1u << m) - 1));
            }
            for (const bool want_normal : {false, true}) {
                BackedOffLanes one, avx;
                fill_refined(a, rays, want_normal, FastLanes::one_by_one, 0x5A, one);
                fill_refined(a, rays, want_normal, FastLanes::avx, 0xA5, avx);
                EXPECT_EQ(std::memcmp(&one.r16, &avx.r16, sizeof one.r16), 0)
                    << "size " << s << " round " << round;
                EXPECT_EQ(std::memcmp(one.valid, avx.valid, sizeof one.valid), 0)
                    << "size " << s << " round " << round;
                for (std::size_t k = 0; k < kLanes; ++k) {
                    const RayContext& x = one.lanes[k];
                    const RayContext& y = avx.lanes[k];
                    EXPECT_TRUE(x.accel == y.accel && x.ray == y.ray && x.frame == y.frame &&
                                x.far == y.far && x.want_normal == y.want_normal &&
                                same_bits(x.len, y.len) && same_bits(x.margin, y.margin) &&
                                same_bits(x.shift, y.shift) &&
                                same_bits(x.origin_err, y.origin_err))
                        << "size " << s << " round " << round << " lane " << k << ": shift "
                        << x.shift << " / " << y.shift << ", len " << x.len << " / " << y.len;
                    if (k < m && !want_normal) {
                        const bool plain = x.ray && !x.far && x.frame == nullptr;
                        (one.valid[k] == -1 ? (plain ? on : special) : off) += 1;
                    }
                }
            }
        }
    }
    EXPECT_GT(on, 1500);  // lanes of every kind were compared
    EXPECT_GT(off, 1000);
    EXPECT_GT(special, 100);
    EXPECT_GT(by_avx, 4000);  // and most were set up by AVX
}

// float_up four values at a time is float_up, for every kind of double (the set-up itself
// meets only positive values and +inf).
TEST(BackedOffLanes, FloatUpOnFourLanesIsFloatUp) {
    if (widest_fast_lanes() != FastLanes::avx)
        GTEST_SKIP() << "this processor has no AVX";
    const double inf = std::numeric_limits<double>::infinity();
    const double fmax = std::numeric_limits<float>::max();
    std::vector<double> values = {0.0,
                                  -0.0,
                                  inf,
                                  -inf,
                                  std::numeric_limits<double>::quiet_NaN(),
                                  fmax,
                                  -fmax,
                                  std::nextafter(fmax, inf),
                                  std::nextafter(-fmax, -inf),
                                  1e39,
                                  -1e39,
                                  std::numeric_limits<double>::denorm_min(),
                                  -std::numeric_limits<double>::denorm_min(),
                                  std::numeric_limits<float>::denorm_min(),
                                  -std::numeric_limits<float>::denorm_min(),
                                  0.5 * std::numeric_limits<float>::denorm_min(),
                                  1.0,
                                  -1.0,
                                  1.0 + 0x1p-30,
                                  -1.0 - 0x1p-30};
    std::mt19937_64 rng(29);
    for (int i = 0; i < 200000; ++i) {  // random bit patterns: every sign, exponent and NaN
        const std::uint64_t bits = rng();
        double v;
        std::memcpy(&v, &bits, sizeof v);
        values.push_back(v);
        values.push_back(static_cast<double>(static_cast<float>(i % 2 ? v : 1.0 / (i + 1))));
    }
    while (values.size() % 4)
        values.push_back(1.0);
    for (std::size_t i = 0; i < values.size(); i += 4) {
        float four[4];
        float_up_four_avx(&values[i], four);
        for (std::size_t j = 0; j < 4; ++j) {
            const double v = values[i + j];
            ASSERT_TRUE(same_bits(four[j], float_up(v)) || (std::isnan(v) && std::isnan(four[j])))
                << v << ": " << four[j] << " / " << float_up(v);
        }
    }
}

// packet_context asks the second ray first (a random packet fails there) and then the whole
// packet: the flag must be coherent() of the whole packet, whichever ray breaks it. Camera
// packets, with one ray among them turned away or moved off at each position in turn, and
// random packets, of every size from 2 to 16.
TEST(PacketContext, FlagsAsTheWholePacketsTest) {
    std::mt19937_64 rng(0xc0de);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const double scale = 4.0;
    int coherent_packets = 0, incoherent_packets = 0;
    for (int round = 0; round < 3000; ++round) {
        const std::size_t m = 2 + static_cast<std::size_t>(round % 15);
        std::vector<Ray> rays;
        const Vec3d eye{u(rng), u(rng), -8.0};
        for (std::size_t k = 0; k < m; ++k)
            rays.push_back(Ray{eye, {0.01 * u(rng), 0.01 * u(rng), 1.0}});
        const std::size_t odd = static_cast<std::size_t>(round / 15) % (m + 1);  // m: none
        switch (round % 4) {
            case 0:  // one ray turned away
                if (odd < m)
                    rays[odd].direction = {1.0, 0.0, 0.2};
                break;
            case 1:  // one origin moved beyond the spread
                if (odd < m)
                    rays[odd].origin = rays[odd].origin + Vec3d{0.5 * scale, 0.0, 0.0};
                break;
            case 2:  // random rays
                for (Ray& r : rays)
                    r = Ray{{u(rng), u(rng), u(rng)}, {u(rng), u(rng), u(rng)}};
                break;
            default:  // the camera's packet as it is
                break;
        }
        const bool together = coherent(
            m, [&](std::size_t k) { return rays[k].direction; },
            [&](std::size_t k) { return rays[k].origin; }, 0.0025 * scale * scale);
        const RTCIntersectContext ctx = packet_context(rays.data(), m, scale);
        EXPECT_EQ(ctx.flags, together ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT
                                      : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT)
            << "round " << round;
        (together ? coherent_packets : incoherent_packets)++;
    }
    EXPECT_GT(coherent_packets, 700);
    EXPECT_GT(incoherent_packets, 1500);
}

}  // namespace
}  // namespace raycastd::engine::embree
