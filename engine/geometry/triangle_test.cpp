#include "engine/geometry/triangle.h"

#include <array>
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

// The triangle a = (0,0,5), b = (2,0,5), c = (0,2,5), facing −z ((b−a)×(c−a) = (0,0,4)).
const Triangle kTri{{0, 0, 5}, {2, 0, 5}, {0, 2, 5}};

Ray toward(double x, double y) {
    return Ray{{x, y, 0}, {0, 0, 1}};
}

TEST(Triangle, Inside) {
    auto hit = intersect_triangle(kTri, toward(0.5, 0.5));
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 5.0);
    EXPECT_DOUBLE_EQ(hit->u, 0.25);  // weight of b: x / 2
    EXPECT_DOUBLE_EQ(hit->v, 0.25);  // weight of c: y / 2
    EXPECT_EQ(hit->normal, (Vec3d{0, 0, 1}));
    EXPECT_FALSE(hit->front_face);  // the ray travels along +z, with the normal
    EXPECT_FALSE(hit->on_edge);
}

TEST(Triangle, Outside) {
    EXPECT_FALSE(intersect_triangle(kTri, toward(1.5, 1.5)));
    EXPECT_FALSE(intersect_triangle(kTri, toward(-0.1, 0.5)));
}

TEST(Triangle, EdgeAndVertexAreInside) {
    auto edge = intersect_triangle(kTri, toward(1.0, 1.0));  // on the hypotenuse bc
    ASSERT_TRUE(edge);
    EXPECT_TRUE(edge->on_edge);
    auto edge_ab = intersect_triangle(kTri, toward(1.0, 0.0));
    ASSERT_TRUE(edge_ab);
    EXPECT_TRUE(edge_ab->on_edge);
    for (const Vec3d& p : {kTri.a, kTri.b, kTri.c}) {
        auto vertex = intersect_triangle(kTri, toward(p.x, p.y));
        ASSERT_TRUE(vertex) << p.x << "," << p.y;
        EXPECT_TRUE(vertex->on_edge);
        EXPECT_EQ(vertex->t, 5.0);
    }
}

TEST(Triangle, RayInPlaneMisses) {
    Ray ray{{-1, 0.5, 5}, {1, 0, 0}};
    EXPECT_FALSE(intersect_triangle(kTri, ray));
}

TEST(Triangle, ParallelOffPlaneMisses) {
    Ray ray{{-1, 0.5, 4}, {1, 0, 0}};
    EXPECT_FALSE(intersect_triangle(kTri, ray));
}

TEST(Triangle, BehindOriginMisses) {
    Ray ray{{0.5, 0.5, 10}, {0, 0, 1}};
    EXPECT_FALSE(intersect_triangle(kTri, ray));
}

TEST(Triangle, BackFaceHitIsReported) {
    Ray ray{{0.5, 0.5, 10}, {0, 0, -1}};
    auto hit = intersect_triangle(kTri, ray);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 5.0);
    EXPECT_TRUE(hit->front_face);
}

TEST(Triangle, DegenerateNeverHitsNorNaN) {
    const Triangle collinear{{0, 0, 5}, {1, 1, 5}, {2, 2, 5}};
    const Triangle point{{1, 1, 5}, {1, 1, 5}, {1, 1, 5}};
    for (const Triangle& t : {collinear, point}) {
        EXPECT_TRUE(is_degenerate(t));
        EXPECT_FALSE(intersect_triangle(t, toward(1, 1)));
        EXPECT_FALSE(intersect_triangle(t, Ray{{0, 0, 0}, {1, 1, 5}}));
        Vec3d n = triangle_normal(t);
        EXPECT_FALSE(std::isnan(n.x) || std::isnan(n.y) || std::isnan(n.z));
    }
}

// Triangles and rays at every scale. The plane crossing multiplies three lengths (n·(v − o))
// and the edge functions two: before 2026-12-05 a triangle 1e110 away missed, one 1e-110 away
// was hit at t = 0, past ~1e154 the normal was NaN and below ~1e-154 a triangle counted as
// degenerate. Lengths and directions beyond 2^±250 are brought to unit scale by a power of two
// (woop_rescaled, unit_scale), so t, the barycentrics and the normal are those of the same
// triangle at scale 1.
TEST(Triangle, HugeAndTinyTrianglesAreHit) {
    for (double s : {1e-300, 1e-200, 1e-160, 1e-155, 1e-150, 1e-120, 1e-110, 1e-100, 1.0, 1e100,
                     1e110, 1e120, 1e150, 1e155, 1e200, 1e300}) {
        const Triangle tri{{-s, -s, 2 * s}, {s, -s, 2 * s}, {0, s, 2 * s}};
        EXPECT_FALSE(is_degenerate(tri)) << s;
        EXPECT_EQ(triangle_normal(tri), (Vec3d{0, 0, 1})) << s;
        // A unit direction (t = 2s), one of the triangle's own scale (t = 2), and an origin off
        // to the side at the triangle's scale.
        const Ray rays[] = {Ray{{0, 0, 0}, {0, 0, 1}}, Ray{{0, 0, 0}, {0, 0, s}},
                            Ray{{-3 * s, 0, 0}, {3 * s, 0, 2 * s}}};
        const double ts[] = {2 * s, 2.0, 1.0};
        for (int k = 0; k < 3; ++k) {
            for (bool fast : {false, true}) {
                const auto h = fast ? intersect_triangle_fast(tri, rays[k], true)
                                    : intersect_triangle(tri, rays[k], true);
                ASSERT_TRUE(h) << s << " ray " << k << " fast " << fast;
                EXPECT_NEAR(h->t, ts[k], h->t_err) << s << " ray " << k << " fast " << fast;
                EXPECT_LE(h->t_err, 1e-12 * ts[k]) << s << " ray " << k;
                if (!fast) {
                    EXPECT_EQ(h->t, ts[k]) << s << " ray " << k;  // exact here: an ulp at most
                }
                EXPECT_NEAR(h->u, 0.25, 1e-12) << s << " ray " << k;
                EXPECT_NEAR(h->v, 0.5, 1e-12) << s << " ray " << k;
                EXPECT_FALSE(h->front_face) << s;
                EXPECT_EQ(h->normal, (Vec3d{0, 0, 1})) << s;
            }
            // And a ray beside it still misses.
            Ray beside = rays[k];
            beside.origin.x += 2 * s;
            EXPECT_FALSE(intersect_triangle(tri, beside)) << s << " ray " << k;
            EXPECT_FALSE(intersect_triangle_fast(tri, beside, false)) << s << " ray " << k;
        }
    }
}

// Rays landing 1 to 100 units inside a corner of a triangle 1e100 to 1e200 across, from 10
// units above it: an edge function there is inf − inf, which std::max had dropped from the
// rescaling test (288 of 2,000 such rays were missed at 1e160; a second review).
TEST(Triangle, CornersOfHugeTrianglesAreHit) {
    for (double S : {1e100, 1e155, 1e160, 1e180, 1e200}) {
        const Triangle t{{S, 2 * S, 0}, {0, 0, 0}, {2 * S, S, 0}};
        std::mt19937_64 rng(1);
        std::uniform_real_distribution<double> U(0, 1);
        int missed = 0;
        for (int k = 0; k < 500; ++k) {
            const double r = 1 + 99 * U(rng);
            const double ang = 0.4636476 + (1.1071487 - 0.4636476) * (0.05 + 0.9 * U(rng));
            const Vec3d target{r * std::cos(ang), r * std::sin(ang), 0};
            Ray ray;
            ray.origin = {3 * U(rng), 3 * U(rng), 10};
            ray.direction = target - ray.origin;
            const auto h = intersect_triangle(t, ray, false);
            missed += !h;
            if (h) {
                EXPECT_NEAR(h->t, 1.0, 1e-12) << S;
            }
        }
        EXPECT_EQ(missed, 0) << S;
    }
}

TEST(Triangle, NonUnitDirection) {
    Ray ray{{0.5, 0.5, 0}, {0, 0, 10}};
    auto hit = intersect_triangle(kTri, ray);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 0.5);
}

TEST(Triangle, TErrorBoundHoldsForExactCase) {
    auto hit = intersect_triangle(kTri, Ray{{0.3, 0.2, 0}, {0.01, 0.02, 1}});
    ASSERT_TRUE(hit);
    EXPECT_LE(std::abs(hit->t - 5.0), hit->t_err);
    EXPECT_GT(hit->t_err, 0.0);
}

// An origin exactly on a vertex gets t = 0 exactly (the plane is anchored at that vertex), and
// on an axis-aligned face too.
TEST(Triangle, OriginOnSurfaceGivesExactZero) {
    const Triangle tilted{{-1.3, 0.7, 12.1}, {3.1, 2.9, 11.7}, {0.3, -2.2, 13.3}};
    for (const Vec3d& v : {tilted.a, tilted.b, tilted.c}) {
        auto hit = intersect_triangle(tilted, Ray{v, {0.3, -0.2, 1}});
        ASSERT_TRUE(hit);
        EXPECT_EQ(hit->t, 0.0);
    }
    auto hit = intersect_triangle(kTri, Ray{{0.25, 0.5, 5}, {0.1, 0.2, -1}});
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 0.0);
}

// A ray at 2⁻³ rad·2⁻³⁰ (~1e-10) to the plane z = 0.5: t = 2⁻³⁰ / 2⁻³³ = 8 exactly. Woop's
// sheared t is off by ~u/cos θ here; the plane crossing in double-double is exact.
TEST(Triangle, NearlyParallelRayExactT) {
    const Triangle big{{-10, -10, 0.5}, {10, -10, 0.5}, {-10, 10, 0.5}};
    const Ray ray{{-9, 0.1, 0.5 - std::ldexp(1.0, -30)}, {1, 0.001, std::ldexp(1.0, -33)}};
    auto hit = intersect_triangle(big, ray);
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->t, 8.0);
    EXPECT_LE(std::abs(hit->t - 8.0), hit->t_err);
}

/// The plane crossing t = n·(a − o) / n·d in GCC's __float128 (the differences and products of
/// the normal exact or nearly; long double would lose ~8 digits of a sliver's normal).
double plane_t_quad(const Triangle& tri, const Ray& ray) {
    using Q = __float128;
    auto q = [](const Vec3d& v) { return std::array<Q, 3>{v.x, v.y, v.z}; };
    const auto a = q(tri.a), b = q(tri.b), c = q(tri.c), o = q(ray.origin), d = q(ray.direction);
    const Q e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const Q e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const Q n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                    e1[0] * e2[1] - e1[1] * e2[0]};
    Q num = 0, den = 0;
    for (std::size_t k = 0; k < 3; ++k) {
        num += n[k] * (a[k] - o[k]);
        den += n[k] * d[k];
    }
    return static_cast<double>(num / den);
}

// A sliver (angle ~1e-8 rad at a): the plane crossing of a ray through its interior, checked
// against the same formula in GCC's __float128 (plane_t_quad).
TEST(Triangle, SliverTToAnUlp) {
    const Triangle sliver{{0.3, -0.2, 4}, {2.3, 0.1, 4.2}, {1.3, -0.05 + 1e-8, 4.1}};
    const Vec3d target = sliver.a * 0.2 + sliver.b * 0.4 + sliver.c * 0.4;
    const Ray ray{{-1, 3, -2}, target - Vec3d{-1, 3, -2}};
    auto hit = triangle_plane_hit(sliver, ray);
    ASSERT_TRUE(hit);
    const double t = plane_t_quad(sliver, ray);
    EXPECT_LE(std::abs(hit->t - t), 2 * (std::nextafter(t, 2 * t) - t));
}

// Watertightness (Woop et al. 2013): a quad split along its diagonal; rays aimed exactly at
// points of the shared diagonal, with jittered origins, always hit at least one of the two.
TEST(Triangle, SharedEdgeNeverLeaks) {
    const Vec3d p0{0.1, 0.3, 2}, p1{3.7, 0.2, 2.5}, p2{3.3, 2.9, 3}, p3{0.2, 3.1, 2.2};
    const Triangle t0{p0, p1, p2}, t1{p0, p2, p3};
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> unit(0.0, 1.0), jitter(-5.0, 5.0);
    int leaks = 0;
    for (int i = 0; i < 20000; ++i) {
        const double s = unit(rng);
        const Vec3d target = p0 + (p2 - p0) * s;
        const Vec3d origin{jitter(rng), jitter(rng), -10.0 + jitter(rng)};
        const Ray ray{origin, target - origin};
        if (!intersect_triangle(t0, ray) && !intersect_triangle(t1, ray))
            ++leaks;
    }
    EXPECT_EQ(leaks, 0);
}

// Large triangles seen from close by, as a render's floor is: coordinate-aligned ones (whose
// normal's rounding lies along the normal only, so the plain-double normal is taken) and tilted
// ones (where it is not, and the double-double normal is), every t to an ulp of the __float128
// crossing. Fails when the plain-double normal is accepted where its error shows in t.
TEST(Triangle, LargeTrianglesFromCloseByToAnUlp) {
    std::mt19937_64 rng(2026);
    std::uniform_real_distribution<double> unit(0.0, 1.0), pos(-3.0, 3.0);
    std::vector<Triangle> tris;
    for (double h : {0.0, 0.099, -1.7, 1e-3}) {
        tris.push_back({{-50, h, -50}, {-50, h, 50}, {50, h, -50}});  // a floor, as bench's
        tris.push_back({{h, -30.3, -30.1}, {h, 30.7, -29.9}, {h, 0.1, 30.2}});
    }
    for (int i = 0; i < 8; ++i) {
        const Vec3d a{pos(rng) * 20, pos(rng) * 20, pos(rng) * 20};
        tris.push_back({a, a + Vec3d{pos(rng), pos(rng), pos(rng)} * 25,
                        a + Vec3d{pos(rng), pos(rng), pos(rng)} * 25});
    }
    int checked = 0;
    for (const Triangle& tri : tris) {
        for (int k = 0; k < 400; ++k) {
            const double u = unit(rng), v = unit(rng) * (1.0 - u);
            const Vec3d target = tri.a + (tri.b - tri.a) * u + (tri.c - tri.a) * v;
            const Vec3d origin = target + Vec3d{pos(rng), pos(rng), pos(rng)};
            const Ray ray{origin, target - origin};
            auto hit = triangle_plane_hit(tri, ray);
            ASSERT_TRUE(hit);
            const double t = plane_t_quad(tri, ray);
            EXPECT_LE(std::abs(hit->t - t), std::nextafter(t, 2 * t) - t)
                << "triangle " << (&tri - tris.data()) << ", ray " << k;
            ++checked;
        }
    }
    EXPECT_EQ(checked, static_cast<int>(tris.size()) * 400);
}

// fast's kernel: Woop's inside test as intersect_triangle's, t from the shear within its own
// t_err of the exact crossing.
TEST(Triangle, FastKernelDecidesAsTheExactOneWithinItsBound) {
    std::mt19937_64 rng(77);
    std::uniform_real_distribution<double> pos(-4.0, 4.0);
    int hits = 0;
    for (int i = 0; i < 20000; ++i) {
        const Vec3d a{pos(rng), pos(rng), pos(rng)};
        const Triangle tri{a, a + Vec3d{pos(rng), pos(rng), pos(rng)} * 0.5,
                           a + Vec3d{pos(rng), pos(rng), pos(rng)} * 0.5};
        const Vec3d o{pos(rng) * 3, pos(rng) * 3, pos(rng) * 3};
        const Ray ray{o, a + Vec3d{pos(rng), pos(rng), pos(rng)} * 0.2 - o};
        const auto exact = intersect_triangle(tri, ray);
        const auto fast = intersect_triangle_fast(tri, ray);
        ASSERT_EQ(fast.has_value(), exact.has_value()) << i;
        if (!fast)
            continue;
        ++hits;
        EXPECT_LE(std::abs(fast->t - exact->t), fast->t_err) << i;
        EXPECT_GT(fast->t_err, 0.0);
        EXPECT_EQ(fast->front_face, exact->front_face);
        EXPECT_EQ(fast->u, exact->u);
        EXPECT_EQ(fast->v, exact->v);
        EXPECT_EQ(fast->normal, exact->normal);
    }
    EXPECT_GT(hits, 2000);
}

// intersect_triangle settles [tmin, tmax] by Woop's sheared t and its t_err where they can,
// without the double-double plane crossing, and decide_triangle takes its hit from them there
// too: both must decide every range as the plane crossing does, and report the crossing they
// leave out (LineCrossing) exactly when it lies outside. Ranges end at the crossing, a few ulps
// and a few t_err on either side of it, and far from it; some triangles and rays are scaled by
// 2^±700 (woop_rescaled), some rays graze their triangle.
TEST(Triangle, RangeSettledByTheShearDecidesAsThePlaneCrossing) {
    std::mt19937_64 rng(2026);
    std::uniform_real_distribution<double> pos(-4.0, 4.0);
    auto steps = [](double t, int n) {
        for (; n > 0; --n)
            t = std::nextafter(t, kInfinity);
        for (; n < 0; ++n)
            t = std::nextafter(t, -kInfinity);
        return t;
    };
    int crossings = 0, checked = 0;
    for (int i = 0; i < 20000; ++i) {
        const double k = i % 8 == 0 ? 0x1p700 : i % 8 == 1 ? 0x1p-700 : 1.0;
        const Vec3d a{pos(rng), pos(rng), pos(rng)};
        const Triangle tri{a * k, (a + Vec3d{pos(rng), pos(rng), pos(rng)} * 0.5) * k,
                           (a + Vec3d{pos(rng), pos(rng), pos(rng)} * 0.5) * k};
        const Vec3d o{pos(rng) * 3, pos(rng) * 3, pos(rng) * 3};
        Vec3d d = a + Vec3d{pos(rng), pos(rng), pos(rng)} * 0.2 - o;
        if (i % 4 == 3) {  // grazing: almost in the triangle's plane
            const Vec3d n = triangle_normal(tri);
            d = d - n * (dot(d, n) * (1.0 - 1e-7));
        }
        // Directions 1/32 to 2^20 long (exact powers of two: the same lines): t_err's bound
        // had fallen short by up to the direction's length (t_error, triangle.cpp).
        const Ray ray{o * k, d * std::ldexp(1.0, static_cast<int>(rng() % 26) - 5)};
        Ray open = ray;
        open.tmin = -kInfinity;
        const auto line = intersect_triangle(tri, open);  // never settled early: the plane's t
        if (!line)
            continue;
        ++crossings;
        const double t = line->t, e = line->t_err;
        for (const double end :
             {t, steps(t, 1), steps(t, -1), steps(t, 4), steps(t, -4), t + e, t - e, t + 2 * e,
              t - 2 * e, t + 8 * e, t - 8 * e, t * 2 + 1, t * 0.5 - 1}) {
            for (const bool is_tmin : {true, false}) {
                Ray r = ray;
                (is_tmin ? r.tmin : r.tmax) = end;
                if (!is_tmin)
                    r.tmin = -kInfinity;
                const bool inside = t >= r.tmin && t <= r.tmax;
                LineCrossing o1, o2;
                const auto h1 = intersect_triangle(tri, r, true, &o1);
                const auto h2 = decide_triangle(tri, r, &o2);
                ++checked;
                ASSERT_EQ(h1.has_value(), inside) << i << " " << end;
                ASSERT_EQ(h2.has_value(), inside) << i << " " << end;
                EXPECT_EQ(o1.crossed, !inside) << i;
                EXPECT_EQ(o2.crossed, !inside) << i;
                if (inside) {
                    EXPECT_EQ(h1->t, t) << i;
                    EXPECT_LE(std::abs(h2->t - t), h2->t_err) << i;
                    EXPECT_EQ(h2->u, line->u);
                    EXPECT_EQ(h2->front_face, line->front_face);
                } else {
                    EXPECT_EQ(o1.u, line->u) << i;
                    EXPECT_EQ(o1.v, line->v) << i;
                    EXPECT_EQ(o2.u, line->u) << i;
                }
            }
        }
    }
    EXPECT_GT(crossings, 2000);
    EXPECT_GT(checked, 50000);
}

// A grazing line (β ≈ 0.048°) along a direction 32 long, where Woop's sheared t is 2.4 of
// pbrt's t_err, as it stood, from the plane crossing (a helper's review): t_err now holds, and
// the range ending at the crossing, or an ulp before it, is decided as the crossing decides.
TEST(Triangle, TErrorHoldsForLongDirections) {
    const Triangle tri{{0x1.39389ad56ee39p+10, 0x1.82c6eff68cd7ep+11, 0x1.1ea4b7d82000ap+10},
                       {-0x1.8019ff082134ap+10, -0x1.7799046cf4d7ap+9, -0x1.9552c279581d3p+10},
                       {0x1.77e75bd2db748p+10, -0x1.2283ee4638567p+11, 0x1.5cd7d9fd39a68p+10}};
    const Ray ray{{0x1.febb13f74801dp+4, 0x1.4b7e394d297eap+5, -0x1.04bd95c02e254p+6},
                  {0x1.6b20ccf84dfdbp+4, -0x1.bb05270dc3a2ap-6, 0x1.68f2175893194p+4}};
    const double t = 0x1.217150d01a051p+2;  // the exact crossing, rounded (rational arithmetic)
    const auto plane = intersect_triangle(tri, ray);
    const auto fast = intersect_triangle_fast(tri, ray);
    ASSERT_TRUE(plane && fast);
    EXPECT_EQ(plane->t, t);
    EXPECT_LE(std::abs(fast->t - t), fast->t_err);
    Ray from_t = ray;
    from_t.tmin = t;
    EXPECT_TRUE(intersect_triangle(tri, from_t));
    EXPECT_TRUE(decide_triangle(tri, from_t));
    Ray before_t = ray;
    before_t.tmax = std::nextafter(t, 0.0);
    LineCrossing outside;
    EXPECT_FALSE(intersect_triangle(tri, before_t));
    EXPECT_FALSE(decide_triangle(tri, before_t, &outside));
    EXPECT_TRUE(outside.crossed);
}

// A hit the sheared t cannot place at or after tmin is not one for fast: a ray leaving a corner
// of the triangle does not find the triangle it leaves, where the exact kernel reports t = 0.
TEST(Triangle, FastKernelReportsNothingItCannotPlaceAfterTmin) {
    const Triangle tilted{{-1.3, 0.7, 12.1}, {3.1, 2.9, 11.7}, {0.3, -2.2, 13.3}};
    const Vec3d p = tilted.a;
    const Ray leaving{p, {0.3, -0.2, 1}};
    const auto exact = intersect_triangle(tilted, leaving);
    ASSERT_TRUE(exact);
    EXPECT_EQ(exact->t, 0.0);
    EXPECT_FALSE(intersect_triangle_fast(tilted, leaving));
    // Arriving at a point inside, it is found where the exact kernel finds it.
    const Vec3d q = tilted.a * 0.3 + tilted.b * 0.3 + tilted.c * 0.4;
    const Ray arriving{q - leaving.direction, leaving.direction};
    const auto fast = intersect_triangle_fast(tilted, arriving);
    ASSERT_TRUE(fast);
    EXPECT_NEAR(fast->t, 1.0, fast->t_err);
}

// A crossing that overflows double (1e300 along a direction 1e-10 long) is no hit, with the
// default tmax = +inf, at both kernels: it had been answered at t = inf. 1,000 times longer, it
// fits.
TEST(Triangle, CrossingsPastTheLargestDoubleAreNoHits) {
    const Triangle tri{{-1e300, -1e300, 1e300}, {1e300, -1e300, 1e300}, {0, 1e300, 1e300}};
    const Ray overflows{{0, 0, 0}, {0, 0, 1e-10}}, fits{{0, 0, 0}, {0, 0, 1e-7}};
    EXPECT_FALSE(intersect_triangle(tri, overflows).has_value());
    EXPECT_FALSE(intersect_triangle_fast(tri, overflows).has_value());
    for (const std::optional<Hit>& h :
         {intersect_triangle(tri, fits), intersect_triangle_fast(tri, fits)}) {
        ASSERT_TRUE(h.has_value());
        EXPECT_NEAR(h->t, 1e307, h->t_err);
    }
}

// An intermediate that overflows where t does not: u·az passes 1.8e308 for a triangle 1e80
// across seen 1e160 away along a unit direction, whose t is 1e160. The fast kernel's sheared t
// came out inf, and was answered so; since the overflow check such a t goes to the rescaled
// retry (a helper's review) and is found there or not at all: the fast kernel's bound, here 1e65
// times t, does not place it after tmin, and it stays silent. The exact kernel finds it, with a
// finite tmax too.
TEST(Triangle, AnIntermediateOverflowIsNotAnswered) {
    const Triangle tri{{-1e80, -1e80, 1e160}, {1e80, -1e80, 1e160}, {0, 1e80, 1e160}};
    for (const double tmax : {kInfinity, 1e200}) {
        Ray ray{{0, 0, 0}, {0, 0, 1}};
        ray.tmax = tmax;
        const std::optional<Hit> exact = intersect_triangle(tri, ray);
        ASSERT_TRUE(exact.has_value()) << tmax;
        EXPECT_NEAR(exact->t, 1e160, exact->t_err) << tmax;
        if (const std::optional<Hit> fast = intersect_triangle_fast(tri, ray)) {
            EXPECT_TRUE(std::isfinite(fast->t)) << tmax;
            EXPECT_NEAR(fast->t, 1e160, fast->t_err) << tmax;
        }
    }
}

// An edge whose edge function double (and long double) round to 0: the line along +z from the
// origin passes beside the edge from b = (2^40, 2^40 + 1) to c = (−(2^40 − 1), −2^40), on the
// side where the triple product is +1 (its products need 80 bits). Of the two triangles that
// share the edge, with a third corner on either side, exactly the one on the line's side is
// hit; the closed test had given the line to both.
TEST(Triangle, EdgeDecidedExactlyWhereDoubleCannot) {
    const double big = 0x1p40;
    const Vec3d b{big, big + 1, 0}, c{-(big - 1), -big, 0};
    const Ray ray{{0, 0, -1}, {0, 0, 1}};
    const Triangle with_line{{-big, big, 0}, b, c};  // the corner on the line's side
    const Triangle beyond{{big, -big, 0}, c, b};     // across the edge, wound the same way
    const auto hit = intersect_triangle(with_line, ray);
    ASSERT_TRUE(hit.has_value());
    EXPECT_FALSE(hit->on_edge);
    EXPECT_EQ(hit->t, 1.0);
    EXPECT_FALSE(intersect_triangle(beyond, ray).has_value());
    // The other way along the same line: the same side decides.
    const Ray back{{0, 0, 1}, {0, 0, -1}};
    EXPECT_TRUE(intersect_triangle(with_line, back).has_value());
    EXPECT_FALSE(intersect_triangle(beyond, back).has_value());
}

}  // namespace
}  // namespace raycastd::engine
