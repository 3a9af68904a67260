#include "engine/geometry/sphere.h"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

Ray ray_z() {
    return Ray{{0, 0, 0}, {0, 0, 1}};
}

double ulp(double x) {
    return std::nextafter(std::abs(x), kInfinity) - std::abs(x);
}

// Tutorial Question 1, sphere 1: (t − 10)² = 2² gives t = 8 and t = 12.
TEST(Sphere, TutorialSphere1) {
    SphereRoots r = sphere_roots({{0, 0, 10}, 2}, ray_z());
    ASSERT_EQ(r.count, 2);
    EXPECT_EQ(r.t[0], 8.0);
    EXPECT_EQ(r.t[1], 12.0);
}

// Sphere 2: 3² + (t − 8)² = 2² has no real roots.
TEST(Sphere, TutorialSphere2Misses) {
    EXPECT_EQ(sphere_roots({{0, 3, 8}, 2}, ray_z()).count, 0);
    EXPECT_FALSE(intersect_sphere({{0, 3, 8}, 2}, ray_z()));
}

// Sphere 3: 1 + (t − 9)² = 4 gives t = 9 ± √3; the first hit is at (0, 0, 9 − √3).
TEST(Sphere, TutorialSphere3) {
    SphereRoots r = sphere_roots({{0, 1, 9}, 2}, ray_z());
    ASSERT_EQ(r.count, 2);
    EXPECT_EQ(r.t[0], 9.0 - std::sqrt(3.0));
    EXPECT_NEAR(r.t[1], 9.0 + std::sqrt(3.0), ulp(10.7));
    auto hit = intersect_sphere({{0, 1, 9}, 2}, ray_z());
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 7.267949192431123);
    // Outward normal at (0, 0, 9 − √3): ((0, −1, −√3))/2.
    EXPECT_NEAR(hit->normal.y, -0.5, 1e-15);
    EXPECT_NEAR(hit->normal.z, -std::sqrt(3.0) / 2, 1e-15);
    EXPECT_TRUE(hit->front_face);
}

// Radius 1 at distance 1e8: the roots are 1e8 ∓ 1, both exactly representable. The textbook
// formula loses every digit of the near root here (b² and 4ac agree to 16 digits).
TEST(Sphere, FarSphereNoCancellation) {
    SphereRoots r = sphere_roots({{0, 0, 1e8}, 1}, ray_z());
    ASSERT_EQ(r.count, 2);
    EXPECT_NEAR(r.t[0], 1e8 - 1, 2 * ulp(1e8));
    EXPECT_NEAR(r.t[1], 1e8 + 1, 2 * ulp(1e8));
    // Off-centre ray at distance 1e8, offset 0.6 in y: roots 1e8 ∓ 0.8.
    r = sphere_roots({{0, 0.6, 1e8}, 1}, ray_z());
    ASSERT_EQ(r.count, 2);
    EXPECT_NEAR(r.t[0], 1e8 - 0.8, 2 * ulp(1e8));
    EXPECT_NEAR(r.t[1], 1e8 + 0.8, 2 * ulp(1e8));
}

// Radius 1e-6 at distance 1e3: t = 1000 ∓ 1e-6.
TEST(Sphere, TinySphere) {
    SphereRoots r = sphere_roots({{0, 0, 1e3}, 1e-6}, ray_z());
    ASSERT_EQ(r.count, 2);
    EXPECT_NEAR(r.t[0], 999.999999, 2 * ulp(1e3));
    EXPECT_NEAR(r.t[1], 1000.000001, 2 * ulp(1e3));
    EXPECT_LT(r.t[0], r.t[1]);
}

// A ray tangent to the sphere (closest approach exactly r) hits once, at the tangent point.
TEST(Sphere, TangentHitsOnce) {
    Sphere s{{0, 1, 5}, 1};
    SphereRoots r = sphere_roots(s, ray_z());
    ASSERT_EQ(r.count, 1);
    EXPECT_EQ(r.t[0], 5.0);
    auto hit = intersect_sphere(s, ray_z());
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 5.0);
    EXPECT_NEAR(hit->normal.y, -1.0, 1e-15);
}

// Origin inside: the hit is the far root, seen from inside (front_face false).
TEST(Sphere, OriginInsideTakesFarRoot) {
    Ray ray{{0, 0, 0}, {0, 0, 2}};
    auto hit = intersect_sphere({{0, 0, 0}, 1}, ray);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 0.5);  // t in units of the given (non-unit) direction
    EXPECT_FALSE(hit->front_face);
    EXPECT_EQ(hit->normal, (Vec3d{0, 0, 1}));
}

// A ray starting in the plane through the centre (β = (o − c)·d = 0, so t_c = −β/a = ±0) has
// roots −h and +h, h = √(r² − ρ²)/|d| for an origin ρ from the centre. Both kernels, with β = +0
// and with β = −0 (every product −0), from the centre and off it; the reference is exact where
// the square root is (ρ = 0) and long double elsewhere. The double-double kernel had told the
// far root's sign from t_c's sign of zero and q's from β's, and given +h twice.
TEST(Sphere, ARayStartingInTheCentrePlaneHasRootsOfBothSigns) {
    struct Case {
        Sphere s;
        Ray ray;
        long double h;
    };
    const long double h_off = std::sqrt(3.75L);  // r = 2, ρ = 0.5
    const Case cases[] = {
        {{{0, 0, 10}, 2}, {{0, 0, 10}, {0, 0, 1}}, 2.0L},              // from the centre
        {{{0, 0, 10}, 2}, {{0, 0, 10}, {0, 0, -4}}, 0.5L},             // a longer direction
        {{{0, 0, 10}, 2}, {{0, 0.5, 10}, {0, 0, 1}}, h_off},           // off the centre, β = +0
        {{{0, 0, 10}, 2}, {{-0.0, 0.5, 10}, {1, -0.0, -0.0}}, h_off},  // β = −0
        {{{-3, 1, -7}, 2}, {{-3, 1.5, -7}, {-0.0, -0.0, -1}}, h_off},  // negative coordinates
    };
    for (const Case& c : cases) {
        for (const bool fast : {false, true}) {
            const SphereRoots r = fast ? sphere_roots_fast(c.s, c.ray) : sphere_roots(c.s, c.ray);
            ASSERT_EQ(r.count, 2) << "fast " << fast << " h " << static_cast<double>(c.h);
            const double want = static_cast<double>(c.h);
            EXPECT_NEAR(r.t[0], -want, 2 * ulp(want)) << "fast " << fast;
            EXPECT_NEAR(r.t[1], want, 2 * ulp(want)) << "fast " << fast;
            EXPECT_LE(std::abs(r.t[1] - c.h), static_cast<long double>(r.t_err));
            // From tmin = −∞ the first hit is the one behind the origin, and a ray going forward
            // from the origin meets the sphere once.
            Ray back = c.ray;
            back.tmin = -kInfinity;
            const auto first = intersect_sphere(c.s, back);
            ASSERT_TRUE(first);
            EXPECT_LT(first->t, 0.0);
            Hit out[2];
            EXPECT_EQ(fast ? sphere_hits_fast(c.s, c.ray, out) : sphere_hits(c.s, c.ray, out), 1);
        }
    }
}

// Radii and distances past ~1.3e154 overflow r² and |f|²: the kernels scale such geometry by
// 2⁻⁶⁰⁰ first (the roots scale back exactly). A ray from inside a sphere of radius 1e155 leaves
// it at t ≈ 1e155 (it had been a miss), and one from 1e300 away meets a sphere of radius 1e299.
// A sphere far smaller than its distance from the origin: r² and |f × d|² both underflowed to
// 0 and every ray near it was a tangent hit (a second review). Now a ray 0.5 radii from the
// centre crosses twice and one 2 radii away misses, at both kernels.
TEST(Sphere, TinySpheresSeenFromAfarAreHitOnlyByRaysThatMeetThem) {
    for (double r : {1e-150, 1e-170, 1e-200, 1e-250}) {
        const Sphere s{{0, 0, 1}, r};
        for (const bool fast : {false, true}) {
            const auto roots = [&](const Ray& ray) {
                return fast ? sphere_roots_fast(s, ray) : sphere_roots(s, ray);
            };
            const SphereRoots in = roots(Ray{{0.5 * r, 0, 0}, {0, 0, 1}});
            ASSERT_EQ(in.count, 2) << r << " " << fast;
            EXPECT_NEAR(in.t[0], 1.0, 1e-15) << r;
            EXPECT_LE(in.t[0], in.t[1]) << r;  // 1 ∓ 0.87r: equal in double below ~1e-16
            EXPECT_EQ(roots(Ray{{2 * r, 0, 0}, {0, 0, 1}}).count, 0) << r << " " << fast;
        }
    }
}

TEST(Sphere, HugeSpheresAreHit) {
    for (const bool fast : {false, true}) {
        auto roots = [&](const Sphere& s, const Ray& r) {
            return fast ? sphere_roots_fast(s, r) : sphere_roots(s, r);
        };
        const SphereRoots a = roots({{0, 0, 5}, 1e155}, ray_z());
        ASSERT_EQ(a.count, 2) << fast;
        EXPECT_NEAR(a.t[1], 1e155 + 5, 1e155 * 1e-15) << fast;
        EXPECT_NEAR(a.t[0], -1e155 + 5, 1e155 * 1e-15) << fast;
        EXPECT_LE(std::abs(a.t[1] - 1e155), a.t_err + 1e155 * 1e-15);
        const Ray far{{0, 0, -1e300}, {0, 0, 1}};
        const SphereRoots b = roots({{0, 0, 0}, 1e299}, far);
        ASSERT_EQ(b.count, 2) << fast;
        EXPECT_NEAR(b.t[0], 0.9e300, 0.9e300 * 1e-15) << fast;
        EXPECT_NEAR(b.t[1], 1.1e300, 1.1e300 * 1e-15) << fast;
    }
    const auto hit = intersect_sphere({{0, 0, 5}, 1e155}, ray_z());
    ASSERT_TRUE(hit);
    EXPECT_NEAR(hit->t, 1e155, 1e140);
    EXPECT_NEAR(length(hit->normal), 1.0, 1e-15);
}

TEST(Sphere, ScaledLengthsAndAShortDirectionDoNotUnderflowToATangent) {
    // A helper's reproducer (2026-12-05): lengths past 2⁵⁰⁰ are scaled by 2⁻⁶⁰⁰, and with a
    // direction 2⁻⁴⁰⁰ long a·r² (2⁻¹⁴⁰⁰) and |f × d|² (2⁻¹⁰⁸⁰) both underflowed to 0: a tangent
    // root at t = 0 for a line that passes 2¹⁶⁰ radii from the centre.
    const Sphere s{{0x1p501, 0, 0}, 0x1p300};
    const Ray beside{{0x1p501, 0x1p460, 0}, {0x1p-400, 0, 0}};
    EXPECT_EQ(sphere_roots(s, beside).count, 0);
    EXPECT_EQ(sphere_roots_fast(s, beside).count, 0);
    EXPECT_FALSE(intersect_sphere(s, beside));
    // The same scales on a line through the centre: both roots, within their bound of
    // (2⁵⁰¹ ∓ 2³⁰⁰)·2⁴⁰⁰, which double rounds to 2⁹⁰¹ (2³⁰⁰ is below its ulp).
    const Ray through{{0, 0, 0}, {0x1p-400, 0, 0}};
    for (const bool fast : {false, true}) {
        const SphereRoots r = fast ? sphere_roots_fast(s, through) : sphere_roots(s, through);
        ASSERT_EQ(r.count, 2) << fast;
        EXPECT_LE(std::abs(r.t[0] - 0x1p901), r.t_err + ulp(0x1p901)) << fast;
        EXPECT_LE(std::abs(r.t[1] - 0x1p901), r.t_err + ulp(0x1p901)) << fast;
    }
}

TEST(Sphere, BehindOriginMisses) {
    EXPECT_FALSE(intersect_sphere({{0, 0, -10}, 2}, ray_z()));
}

TEST(Sphere, RespectsInclusiveRange) {
    Ray ray = ray_z();
    ray.tmax = 8.0;  // inclusive: t = 8 still counts
    auto hit = intersect_sphere({{0, 0, 10}, 2}, ray);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 8.0);
    ray.tmax = std::nextafter(8.0, 0.0);
    EXPECT_FALSE(intersect_sphere({{0, 0, 10}, 2}, ray));
    ray.tmin = 9.0;
    ray.tmax = kInfinity;
    hit = intersect_sphere({{0, 0, 10}, 2}, ray);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 12.0);
}

// Scaling the direction by k divides t by k, for extreme k.
TEST(Sphere, DirectionScaleInvariance) {
    for (double k : {1e-6, 1e-3, 0.5, 3.0, 1e3, 1e6}) {
        Ray ray{{0, 0, 0}, {0, 0, k}};
        auto hit = intersect_sphere({{0, 1, 9}, 2}, ray);
        ASSERT_TRUE(hit) << k;
        EXPECT_NEAR(hit->t * k, 9.0 - std::sqrt(3.0), 4 * ulp(7.27)) << k;
    }
}

// An origin exactly on the sphere: the near root is exactly 0 (γ = f·f − r² is formed in
// double-double, so it is exactly zero), the far one exactly the chord.
TEST(Sphere, OriginOnSurfaceGivesExactZero) {
    const Sphere s{{0.5, 0.25, 8}, 2};
    SphereRoots r = sphere_roots(s, Ray{{0.5, 0.25, 6}, {0, 0, 1}});
    ASSERT_EQ(r.count, 2);
    EXPECT_EQ(r.t[0], 0.0);
    EXPECT_EQ(r.t[1], 4.0);
    r = sphere_roots(s, Ray{{2.5, 0.25, 8}, {-0.5, 0, 0}});  // leaving inwards, |d| = 0.5
    ASSERT_EQ(r.count, 2);
    EXPECT_EQ(r.t[0], 0.0);
    EXPECT_EQ(r.t[1], 8.0);
}

// A ray passing at distance r·(1 − 2⁻⁴⁰) from the centre, along a direction that is not an axis
// (so no component makes the arithmetic exact): the half-chord √(r² − dist²) ≈ 1.3e-6·r must come
// out to a few ulps of t, which a double discriminant cannot give (it loses ~12 of 16 digits).
TEST(Sphere, NearTangentRootsToAnUlp) {
    // The line through p = c + w·dist with direction u ⟂ w; w, u built from a Pythagorean triple
    // so that both are exact and exactly perpendicular: w = (3, 4, 0)/5, u = (−4, 3, 0)/5 · k.
    const double dist = 1.0 - std::ldexp(1.0, -40);
    const Sphere s{{0, 0, 0}, 1};
    const Vec3d p{0.6 * dist, 0.8 * dist, 0};  // rounded: the true distance is |p| = dist(1 ± u)
    const Ray ray{p - Vec3d{-0.8, 0.6, 0} * 10.0, Vec3d{-0.8, 0.6, 0}};
    const SphereRoots r = sphere_roots(s, ray);
    ASSERT_EQ(r.count, 2);
    // The roots from the rounded inputs: t = t_c ∓ √(a·r² − |f × d|²)/a. The discriminant is
    // formed in GCC's __float128 (every product of two doubles is exact there), whose value
    // long double's √ then takes to 64 bits: far more than the 2 ulps asked.
    using Q = __float128;
    const Q ox = ray.origin.x, oy = ray.origin.y, dx = ray.direction.x, dy = ray.direction.y;
    const Q a = dx * dx + dy * dy, beta = ox * dx + oy * dy;
    const Q cr = ox * dy - oy * dx;  // |f × d| (z components are zero)
    const long double h =
        std::sqrt(static_cast<long double>(a - cr * cr)) / static_cast<long double>(a);
    const long double tc = static_cast<long double>(-beta / a);
    EXPECT_NEAR(r.t[0], static_cast<double>(tc - h), 2 * ulp(10.0));
    EXPECT_NEAR(r.t[1], static_cast<double>(tc + h), 2 * ulp(10.0));
}

// Lines from 2^40 to 2^73 away, passing 10^-9 to 10^-12 of a radius inside or outside a sphere
// 2e-6 across. Each passes exactly through the world origin (o = −2^K·d: a power of two times
// d), so its distance from the centre is |c × d|/|d|, which long double gives to ~1e-18 of the
// radius. Until cross_far the double-double cross product rounded by u²·|f|·|d|, and from
// ~2^63 away most of these were decided wrongly (a probe: 808 of 2,000 at 1e-9 of tangency
// from 2^63, 982 from 2^68); the normal, formed from the rounded t, was (0, 0, 0) from ~2^52 on.
TEST(Sphere, FarNearTangentLinesAreDecidedExactly) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(-1, 1), exponent(9, 12), distance(40, 73);
    const double r = 1e-6;
    for (int j = 0; j < 400; ++j) {
        Vec3d c;
        do {
            c = Vec3d{u(rng), u(rng), u(rng)} * 4e-5;
        } while (length(c) < 8e-6);
        // The line through the origin and c + ρ0·e (e ⟂ c) passes at r·(1 ± 10^-x) from c.
        const Vec3d e = normalize(cross(c, Vec3d{u(rng), u(rng), u(rng)}));
        const double want = r * (1.0 + (j % 2 ? 1.0 : -1.0) * std::pow(10.0, -exponent(rng)));
        const Vec3d d = normalize(c + e * (want * length(c) / std::sqrt(dot(c, c) - want * want)));
        const Ray ray{-d * std::ldexp(1.0, static_cast<int>(distance(rng))), d};
        const long double cx = c.x, cy = c.y, cz = c.z, dx = d.x, dy = d.y, dz = d.z;
        const long double x = cy * dz - cz * dy, y = cz * dx - cx * dz, z = cx * dy - cy * dx;
        const long double dist = std::sqrt((x * x + y * y + z * z) / (dx * dx + dy * dy + dz * dz));
        SCOPED_TRACE(::testing::Message() << "line " << j << " at 2^" << std::ilogb(ray.origin.x)
                                          << ": distance/r − 1 = " << double(dist / r - 1));
        Hit hits[2];
        const int n = sphere_hits(Sphere{c, r}, ray, hits);
        ASSERT_EQ(n > 0, dist < r);
        const double nd =
            std::sqrt(std::max(0.0, 1.0 - static_cast<double>(dist * dist / (r * r))));
        for (int k = 0; k < n; ++k) {
            EXPECT_EQ(hits[k].front_face, k == 0);
            EXPECT_NEAR(length(hits[k].normal), 1.0, 1e-15);
            EXPECT_NEAR(dot(hits[k].normal, d), k == 0 ? -nd : nd, 1e-9);
        }
    }
}

// The far normal (closest approach and half-chord) at extreme scales: lengths near 2^±900 and
// directions 2^±900 or 2^-600 long, where its products had left double's range and the plain
// form, o + t·d − c from the rounded t, answered (0, 1, 0) or (0, 0, 0) (a helper's review).
// Each line crosses the sphere at 60° from its axis, or through its centre.
TEST(Sphere, FarNormalsAtExtremeScales) {
    struct Case {
        Sphere s;
        Ray ray;
        Vec3d near;  // the outward normal at the entry; the exit's mirrors its x (or x and y)
        bool through_centre;
    };
    const double h = std::sqrt(3.0) / 2;
    const Case cases[] = {
        {{{0, 0, 0}, 0x1p900}, {{-0x1p980, 0x1p899, 0}, {1, 0, 0}}, {-h, 0.5, 0}, false},
        {{{0, 0, 0}, 0x1p-900}, {{-0x1p-840, 0x1p-901, 0}, {1, 0, 0}}, {-h, 0.5, 0}, false},
        {{{0, 0, 0}, 1}, {{-0x1p60, 0.5, 0}, {0x1p-900, 0, 0}}, {-h, 0.5, 0}, false},
        {{{0, 0, 0}, 1}, {{-0x1p60, 0.5, 0}, {0x1p900, 0, 0}}, {-h, 0.5, 0}, false},
        {{{0, 0, 0}, 1},
         {{-0x1p60, -0x1p60, 0}, {0x1p-600, 0x1p-600, 0}},
         {-std::sqrt(0.5), -std::sqrt(0.5), 0},
         true},
        // (A second review.) A subnormal radius, whose power of two to 1 is inf; a line 2^501
        // radii away, beyond what the lengths' scaling had allowed; a direction 2^520 long,
        // whose d·d overflows (the roots themselves had been missed).
        {{{0, 0, 0}, 0x1p-1074}, {{-1e-300, 0, 0}, {1, 0, 0}}, {-1, 0, 0}, true},
        {{{0, 0, 0}, 1}, {{-0x1p501, 0.6, 0}, {1, 0, 0}}, {-0.8, 0.6, 0}, false},
        {{{0, 0, 0}, 0x1p-100}, {{-0x1p-98, 0x1p-101, 0}, {0x1p520, 0, 0}}, {-h, 0.5, 0}, false},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(::testing::Message()
                     << "radius " << c.s.radius << ", origin x " << c.ray.origin.x
                     << ", direction x " << c.ray.direction.x);
        Hit hits[2];
        ASSERT_EQ(sphere_hits(c.s, c.ray, hits), 2);
        EXPECT_EQ(sphere_roots_fast(c.s, c.ray).count, 2);  // fast's kernel finds them too
        const Vec3d far_side = c.through_centre ? -c.near : Vec3d{-c.near.x, c.near.y, 0};
        for (int k = 0; k < 2; ++k) {
            const Vec3d want = k == 0 ? c.near : far_side;
            EXPECT_EQ(hits[k].front_face, k == 0);
            EXPECT_NEAR(hits[k].normal.x, want.x, 1e-15) << k;
            EXPECT_NEAR(hits[k].normal.y, want.y, 1e-15) << k;
            EXPECT_NEAR(hits[k].normal.z, want.z, 1e-15) << k;
        }
    }
}

// o − c past the largest double (an origin at -1e308, a centre at 1e308) while both roots fit:
// the normal had come out NaN (JSON's null) with front_face false (a helper's review).
TEST(Sphere, NormalsWhereOriginMinusCentreOverflows) {
    const double h = std::sqrt(3.0) / 2;
    const Sphere s{{1e308, 0, 0}, 5e307};
    for (const Ray& ray :
         {Ray{{-1e308, 2.5e307, 0}, {2, 0, 0}}, Ray{{-1e308, 2.5e307, 0}, {1, 0, 0}}}) {
        SCOPED_TRACE(ray.direction.x);
        Hit hits[2];
        const int n = sphere_hits(s, ray, hits);
        ASSERT_EQ(n, ray.direction.x == 2 ? 2 : 1);  // the far root overflows at direction 1
        for (int k = 0; k < n; ++k) {
            const Vec3d want = k == 0 ? Vec3d{-h, 0.5, 0} : Vec3d{h, 0.5, 0};
            EXPECT_EQ(hits[k].front_face, k == 0) << k;
            EXPECT_NEAR(hits[k].normal.x, want.x, 1e-15) << k;
            EXPECT_NEAR(hits[k].normal.y, want.y, 1e-15) << k;
            EXPECT_EQ(hits[k].normal.z, 0.0) << k;
        }
        const std::optional<Hit> first = intersect_sphere(s, ray);
        ASSERT_TRUE(first);
        EXPECT_EQ(first->t, hits[0].t);
        EXPECT_EQ(first->normal, hits[0].normal);
        EXPECT_TRUE(first->front_face);
    }
}

// Which root a normal belongs to is passed on where it is known: from 2^40 away the two roots
// of a line 1e-8 of a radius inside a unit sphere round to neighbouring doubles, and with tmin
// at the second one, the normal recomputed from t alone took the near side, front_face true
// (a helper's review; EmbreeAccel's answers had recomputed it so).
TEST(Sphere, NormalsKnowWhichRootTheyAreAt) {
    const Sphere s{{0, 0, 0}, 1};
    Ray ray{{-0x1p40, std::sqrt(1 - 1e-8), 0}, {1, 0, 0}};
    const SphereRoots r = sphere_roots(s, ray);
    ASSERT_EQ(r.count, 2);
    ASSERT_EQ(r.t[1], 0x1p40);
    ray.tmin = r.t[1];
    const auto h = intersect_sphere(s, ray, true);
    ASSERT_TRUE(h);
    EXPECT_FALSE(h->front_face);
    EXPECT_GT(h->normal.x, 0.0);
    Hit by_side;
    sphere_normal(s, ray, h->t, root_side(r, 1), by_side);
    EXPECT_EQ(by_side.normal, h->normal);
    EXPECT_FALSE(by_side.front_face);
    // Told by t alone, where the scales' ratio 2^600/2^-430 overflows but the scaled t does not
    // (a second review: the far root's normal came back for the entry).
    const Sphere tiny{{0, 0, 0}, 0x1p-600};
    const Ray long_ray{{-0x1p-560, 0.6 * 0x1p-600, 0}, {0x1p430, 0, 0}};
    Hit hits[2];
    ASSERT_EQ(sphere_hits(tiny, long_ray, hits), 2);
    Hit by_t;
    sphere_normal(tiny, long_ray, hits[0].t, by_t);
    EXPECT_TRUE(by_t.front_face);
    EXPECT_NEAR(by_t.normal.x, -0.8, 1e-15);
}

// A radius of 2^-1074 with an origin as small: the tiny-radius scaling's power of two was inf,
// and the call recursed until the stack ran out (a helper's review).
TEST(Sphere, SmallestRadiusIsAnsweredWithoutRecursingForEver) {
    const Sphere s{{0, 0, 0}, 0x1p-1074};
    const SphereRoots r = sphere_roots(s, Ray{{-0x1p-1074, 0, 0}, {1, 0, 0}});
    ASSERT_EQ(r.count, 2);
    EXPECT_EQ(r.t[0], 0.0);
    EXPECT_EQ(r.t[1], 0x1p-1073);
}

// Below 2⁻⁹⁰⁰ of its distance a sphere is taken as missed, even by a line through its centre
// (docs/numerics.md), and says so: the worked solution gives that reason rather than "no real
// roots". Ordinary misses, and a small sphere that can be scaled up, are not flagged.
TEST(Sphere, SpheresBelowDoublesResolutionAreFlagged) {
    const SphereRoots lost = sphere_roots({{0, 0, 5}, 1e-300}, ray_z());
    EXPECT_EQ(lost.count, 0);
    EXPECT_TRUE(lost.unresolved);
    const SphereRoots scaled = sphere_roots({{0, 0, 5}, 1e-200}, ray_z());
    EXPECT_EQ(scaled.count, 2);
    EXPECT_FALSE(scaled.unresolved);
    const SphereRoots missed = sphere_roots({{3, 0, 5}, 1}, ray_z());
    EXPECT_EQ(missed.count, 0);
    EXPECT_FALSE(missed.unresolved);
}

TEST(Sphere, ErrorBoundCoversFarSphere) {
    SphereRoots r = sphere_roots({{0, 0, 1e8}, 1}, ray_z());
    EXPECT_GT(r.t_err, 0.0);
    EXPECT_LT(r.t_err, 1e-6);
}

// fast's plain-double kernel against the double-double one: the same roots to within the
// t_err it reports, on ordinary rays, near tangency, from inside; and for the cases plain
// double cannot form (|o − c|² overflowing, r² underflowing) it hands over to the other.
TEST(Sphere, SubnormalDirectionLengthStillHits) {
    // |d|² a few subnormal steps: the plain-double miss test's rounding is not relative there,
    // and it took this ray, starting inside the sphere, for a miss (a helper's review).
    const Sphere s{{0, 0, 0}, 1e100};
    const double k = 1.2247 * 0x1p-537;
    const Ray r{{6e99, -6e99, 0}, {k, k, k}};
    const auto exact = intersect_sphere(s, r);
    ASSERT_TRUE(exact.has_value());
    EXPECT_GT(exact->t, 0.0);
    EXPECT_TRUE(first_hit_of_roots(s, r, sphere_roots_fast(s, r), false).has_value());
}

TEST(Sphere, FastRootsWithinTheirBound) {
    std::mt19937_64 rng(77);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    int compared = 0;
    for (int i = 0; i < 20000; ++i) {
        const Sphere s{{u(rng) * 10, u(rng) * 10, u(rng) * 10}, 0.1 + std::abs(u(rng)) * 3};
        Ray ray;
        ray.origin = {u(rng) * 20, u(rng) * 20, u(rng) * 20};
        // aim near the sphere's rim so that tangency is common
        const Vec3d target =
            s.center + normalize(Vec3d{u(rng), u(rng), u(rng)}) * s.radius * (1.0 + 1e-9 * u(rng));
        ray.direction = (target - ray.origin) * std::pow(10.0, 3 * u(rng));
        const SphereRoots ref = sphere_roots(s, ray);
        const SphereRoots fast = sphere_roots_fast(s, ray);
        if (ref.count == 0 || fast.count == 0)
            continue;  // near tangency the two may disagree on a graze, within the bound
        ++compared;
        for (int k = 0; k < 2; ++k) {
            EXPECT_LE(std::abs(fast.t[k] - ref.t[std::min(k, ref.count - 1)]),
                      fast.t_err + ref.t_err)
                << "ray " << i;
        }
        EXPECT_TRUE(std::isfinite(fast.t_err));
    }
    EXPECT_GT(compared, 15000);

    const Sphere unit{{0, 0, 0}, 1.0};
    const Ray far{{-1e200, 0, 0}, {1, 0, 0}};  // |f|² overflows in plain double
    const SphereRoots a = sphere_roots_fast(unit, far), b = sphere_roots(unit, far);
    ASSERT_EQ(a.count, b.count);
    EXPECT_EQ(a.t[0], b.t[0]);
    EXPECT_EQ(a.t[1], b.t[1]);
    const Sphere tiny{{0, 0, 0}, 1e-170};  // r² underflows
    const Ray through{{-1, 0, 0}, {1, 0, 0}};
    const SphereRoots c = sphere_roots_fast(tiny, through), d = sphere_roots(tiny, through);
    EXPECT_EQ(c.count, d.count);
    EXPECT_FALSE(std::isnan(c.t_err));
}

// A root that overflows double (9e299 along a direction 1e-10 long) is no hit, with the default
// tmax = +inf: it had been answered at t = inf with a NaN normal. 1,000 times longer, it fits.
TEST(Sphere, RootsPastTheLargestDoubleAreNoHits) {
    const Sphere s{{0, 0, 1e300}, 1e299};
    const Ray overflows{{0, 0, 0}, {0, 0, 1e-10}}, fits{{0, 0, 0}, {0, 0, 1e-7}};
    Hit out[2];
    EXPECT_FALSE(intersect_sphere(s, overflows).has_value());
    EXPECT_EQ(sphere_hits(s, overflows, out), 0);
    EXPECT_EQ(sphere_hits_fast(s, overflows, out), 0);
    const std::optional<Hit> h = intersect_sphere(s, fits);
    ASSERT_TRUE(h.has_value());
    EXPECT_NEAR(h->t, 9e306, h->t_err);
    EXPECT_EQ(sphere_hits(s, fits, out), 2);
    EXPECT_TRUE(std::isfinite(out[1].t));
}

}  // namespace
}  // namespace raycastd::engine
