#include "engine/geometry/closest_point.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

// The triangle a = (0,0,0), b = (2,0,0), c = (0,2,0) in the plane z = 0.
const Triangle kTri{{0, 0, 0}, {2, 0, 0}, {0, 2, 0}};

ClosestPoint on_tri(const Vec3d& p) {
    auto c = closest_point_on_triangle(kTri, p);
    EXPECT_TRUE(c);
    return c ? *c : ClosestPoint{};
}

TEST(ClosestPoint, FaceRegion) {
    const ClosestPoint c = on_tri({0.5, 0.5, 3});
    EXPECT_EQ(c.point, (Vec3d{0.5, 0.5, 0}));
    EXPECT_EQ(c.distance, 3.0);
    EXPECT_DOUBLE_EQ(c.u, 0.25);
    EXPECT_DOUBLE_EQ(c.v, 0.25);
    const ClosestPoint below = on_tri({0.5, 0.5, -3});  // the side does not matter
    EXPECT_EQ(below.distance, 3.0);
}

TEST(ClosestPoint, VertexRegions) {
    const ClosestPoint a = on_tri({-1, -1, 1});
    EXPECT_EQ(a.point, kTri.a);
    EXPECT_EQ(a.distance, std::sqrt(3.0));
    EXPECT_EQ(a.u, 0.0);
    EXPECT_EQ(a.v, 0.0);
    const ClosestPoint b = on_tri({5, -1, 0});
    EXPECT_EQ(b.point, kTri.b);
    EXPECT_EQ(b.u, 1.0);
    const ClosestPoint c = on_tri({-0.5, 4, 0});
    EXPECT_EQ(c.point, kTri.c);
    EXPECT_EQ(c.v, 1.0);
}

TEST(ClosestPoint, EdgeRegions) {
    const ClosestPoint ab = on_tri({1, -2, 0});
    EXPECT_EQ(ab.point, (Vec3d{1, 0, 0}));
    EXPECT_EQ(ab.distance, 2.0);
    EXPECT_DOUBLE_EQ(ab.u, 0.5);
    EXPECT_EQ(ab.v, 0.0);
    const ClosestPoint ac = on_tri({-3, 1.5, 4});
    EXPECT_EQ(ac.point, (Vec3d{0, 1.5, 0}));
    EXPECT_EQ(ac.distance, 5.0);
    EXPECT_EQ(ac.u, 0.0);
    EXPECT_DOUBLE_EQ(ac.v, 0.75);
    const ClosestPoint bc = on_tri({2, 2, 0});  // beyond the hypotenuse
    EXPECT_DOUBLE_EQ(bc.point.x, 1.0);
    EXPECT_DOUBLE_EQ(bc.point.y, 1.0);
    EXPECT_DOUBLE_EQ(bc.distance, std::sqrt(2.0));
    EXPECT_DOUBLE_EQ(bc.u, 0.5);
    EXPECT_DOUBLE_EQ(bc.v, 0.5);
}

// The regions of FaceRegion, VertexRegions and EdgeRegions with the triangle and the point scaled
// from 1e-300 to 1e300: the same barycentrics, the point and distance scaled (four lengths are
// multiplied in the region tests; at 1e78 they had overflowed into a null barycentric, at 1e155
// into a null distance). A sphere likewise.
TEST(ClosestPoint, EveryScaleGivesTheSameAnswer) {
    const Vec3d points[] = {{0.5, 0.5, 3}, {-1, -1, 1},  {5, -1, 0},
                            {1, -2, 0},    {-3, 1.5, 4}, {2, 2, 0}};
    for (double s : {1e-300, 1e-160, 1e-78, 1.0, 1e78, 1e155, 1e300}) {
        const Triangle tri{kTri.a * s, kTri.b * s, kTri.c * s};
        for (const Vec3d& p : points) {
            const ClosestPoint want = *closest_point_on_triangle(kTri, p);
            const auto got = closest_point_on_triangle(tri, p * s);
            ASSERT_TRUE(got) << s;
            EXPECT_NEAR(got->u, want.u, 1e-15) << s;
            EXPECT_NEAR(got->v, want.v, 1e-15) << s;
            EXPECT_NEAR(got->distance / s, want.distance, 1e-15 * want.distance) << s;
            EXPECT_NEAR(got->point.x / s, want.point.x, 1e-15) << s;
            EXPECT_NEAR(got->point.y / s, want.point.y, 1e-15) << s;
            EXPECT_TRUE(std::isfinite(got->err)) << s;
        }
        const Sphere ball{{s, 0, 0}, s};
        const ClosestPoint c = closest_point_on_sphere(ball, Vec3d{s, 3 * s, 4 * s});
        EXPECT_NEAR(c.distance / s, 4.0, 1e-15) << s;
        EXPECT_NEAR(c.point.y / s, 0.6, 1e-15) << s;
        EXPECT_NEAR(c.point.z / s, 0.8, 1e-15) << s;
    }
}

TEST(ClosestPoint, FarPointsKeepTheirDigits) {
    const ClosestPoint face = on_tri({0.5, 0.25, 1e12});
    EXPECT_EQ(face.distance, 1e12);
    EXPECT_EQ(face.point, (Vec3d{0.5, 0.25, 0}));
    const ClosestPoint vertex = on_tri({-3e9, -4e9, 0});
    EXPECT_EQ(vertex.distance, 5e9);
    EXPECT_EQ(vertex.point, kTri.a);
}

TEST(ClosestPoint, PointsOnTheSurfaceAreWithinTheBound) {
    // On the face, on each edge and at each vertex: distance 0 or within err (the caller then
    // reports 0: engine/points).
    const Vec3d on[] = {{0.5, 0.5, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, kTri.a, kTri.b, kTri.c};
    for (const Vec3d& p : on) {
        const ClosestPoint c = on_tri(p);
        EXPECT_LE(c.distance, c.err) << p.x << " " << p.y;
        EXPECT_GT(c.err, 0.0);
    }
    // The centroid of a tilted triangle far from the origin is off its plane by rounding only.
    const Triangle far{{1e6 + 0.1, 3, 7}, {1e6 + 1.3, 4.7, 7.9}, {1e6 - 0.4, 3.3, 9.1}};
    const Vec3d g = (far.a + far.b + far.c) / 3.0;
    auto c = closest_point_on_triangle(far, g);
    ASSERT_TRUE(c);
    EXPECT_LE(c->distance, c->err);
}

TEST(ClosestPoint, DegenerateTrianglesGiveNoPoint) {
    EXPECT_FALSE(closest_point_on_triangle({{0, 0, 0}, {1, 1, 1}, {2, 2, 2}}, {0, 1, 0}));
    EXPECT_FALSE(closest_point_on_triangle({{0, 0, 0}, {0, 0, 0}, {1, 0, 0}}, {0, 1, 0}));
    EXPECT_FALSE(closest_point_on_triangle(kTri, {std::nan(""), 0, 0}));
}

TEST(ClosestPoint, SharedEdgesAndVerticesTieBitForBit) {
    // Two triangles of a roof sharing the ridge p0–p1, listed in opposite directions; a point
    // above the ridge (in both faces' edge regions) is closest to it in both.
    const Vec3d p0{0.1, 0.3, 1.7}, p1{2.9, 0.3, 1.7};
    const Triangle left{p0, p1, {1.3, -1.7, 0.7}};
    const Triangle right{p1, p0, {1.7, 2.3, 0.7}};
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> s(0.05, 0.95), h(0.1, 3.0), side(-0.4, 0.4);
    int same = 0;
    for (int i = 0; i < 1000; ++i) {
        // Inside both edge regions: above the ridge by b, sideways by at most 0.4·b (each face
        // falls away from the ridge with slope 1/2).
        const double b = h(rng);
        const Vec3d p = p0 + (p1 - p0) * s(rng) + Vec3d{0, side(rng) * b, b};
        auto l = closest_point_on_triangle(left, p);
        auto r = closest_point_on_triangle(right, p);
        ASSERT_TRUE(l && r);
        if (l->point == r->point) {
            EXPECT_EQ(l->distance, r->distance);
            ++same;
        } else {
            // One of them took its face region by a rounding: the distances then tie within
            // the bounds.
            EXPECT_LE(std::abs(l->distance - r->distance), l->err + r->err);
        }
    }
    EXPECT_GT(same, 900);
    // A shared vertex: the vertex itself, from every triangle around it.
    const Vec3d apex{0.3, 0.7, 0.9};
    auto t1 = closest_point_on_triangle({apex, {1, 0, 0}, {0, 1, 0}}, {0.3, 0.7, 5});
    auto t2 = closest_point_on_triangle({{0, 1, 0}, {-1, 0, 0}, apex}, {0.3, 0.7, 5});
    ASSERT_TRUE(t1 && t2);
    EXPECT_EQ(t1->point, apex);
    EXPECT_EQ(t2->point, apex);
    EXPECT_EQ(t1->distance, t2->distance);
}

// --- Against a long-double evaluation of the same regions ------------------------------------

using L = long double;
struct V3 {
    L x, y, z;
};
V3 sub(V3 a, V3 b) {
    return {a.x - b.x, a.y - b.y, a.z - b.z};
}
L dotl(V3 a, V3 b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
V3 axpy(V3 a, V3 d, L s) {
    return {a.x + d.x * s, a.y + d.y * s, a.z + d.z * s};
}
V3 wide(const Vec3d& v) {
    return {v.x, v.y, v.z};
}

/// Ericson's method (RTCD §5.1.5) as printed, in long double (64-bit significand).
L reference_distance(const Triangle& t, const Vec3d& pd) {
    const V3 a = wide(t.a), b = wide(t.b), c = wide(t.c), p = wide(pd);
    const V3 ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
    const L d1 = dotl(ab, ap), d2 = dotl(ac, ap);
    auto dist = [&](V3 q) { return std::sqrt(dotl(sub(p, q), sub(p, q))); };
    if (d1 <= 0 && d2 <= 0)
        return dist(a);
    const V3 bp = sub(p, b);
    const L d3 = dotl(ab, bp), d4 = dotl(ac, bp);
    if (d3 >= 0 && d4 <= d3)
        return dist(b);
    const L vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0)
        return dist(axpy(a, ab, d1 / (d1 - d3)));
    const V3 cp = sub(p, c);
    const L d5 = dotl(ab, cp), d6 = dotl(ac, cp);
    if (d6 >= 0 && d5 <= d6)
        return dist(c);
    const L vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0)
        return dist(axpy(a, ac, d2 / (d2 - d6)));
    const L va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
        return dist(axpy(b, sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6))));
    const L denom = 1 / (va + vb + vc);
    return dist(axpy(axpy(a, ab, vb * denom), ac, vc * denom));
}

TEST(ClosestPoint, AgreesWithALongDoubleReference) {
    std::mt19937_64 rng(2024);
    std::uniform_real_distribution<double> box(-1, 1);
    auto rnd = [&](double s, const Vec3d& o) {
        return o + Vec3d{box(rng), box(rng), box(rng)} * s;
    };
    double worst = 0;  // |error| / (u · scale)
    for (int i = 0; i < 200000; ++i) {
        // Triangles of size 1 at offsets up to 1e4, points near them and far from them.
        const Vec3d o = rnd(i % 3 == 0 ? 1e4 : 1.0, {0, 0, 0});
        const Triangle t{rnd(1, o), rnd(1, o), rnd(1, o)};
        const Vec3d p = rnd(i % 5 == 0 ? 100.0 : 1.5, o);
        auto c = closest_point_on_triangle(t, p);
        if (!c)
            continue;
        const L ref = reference_distance(t, p);
        const double err = static_cast<double>(std::abs(static_cast<L>(c->distance) - ref));
        ASSERT_LE(err, c->err) << i;
        worst = std::max(worst, err / (c->err / 16.0));
        // The point lies on the triangle: barycentrics in the closed simplex.
        EXPECT_GE(c->u, 0.0);
        EXPECT_GE(c->v, 0.0);
        EXPECT_LE(c->u + c->v, 1.0 + 1e-12);
    }
    std::printf("closest point on triangle: worst distance error %.2f u·scale (bound 16)\n", worst);
}

TEST(ClosestPoint, NoSampledPointOfTheTriangleIsCloser) {
    std::mt19937_64 rng(99);
    std::uniform_real_distribution<double> box(-2, 2), unit(0, 1);
    for (int i = 0; i < 2000; ++i) {
        const Triangle t{{box(rng), box(rng), box(rng)},
                         {box(rng), box(rng), box(rng)},
                         {box(rng), box(rng), box(rng)}};
        const Vec3d p{box(rng), box(rng), box(rng)};
        auto c = closest_point_on_triangle(t, p);
        ASSERT_TRUE(c);
        for (int k = 0; k < 200; ++k) {
            double u = unit(rng), v = unit(rng);
            if (u + v > 1) {
                u = 1 - u;
                v = 1 - v;
            }
            const Vec3d x = t.a * (1 - u - v) + t.b * u + t.c * v;
            ASSERT_LE(c->distance, length(p - x) + c->err);
        }
    }
}

TEST(ClosestPoint, Sphere) {
    const Sphere s{{1, 2, 3}, 2};
    const ClosestPoint out = closest_point_on_sphere(s, {1, 2, 13});
    EXPECT_EQ(out.point, (Vec3d{1, 2, 5}));
    EXPECT_EQ(out.distance, 8.0);
    const ClosestPoint in = closest_point_on_sphere(s, {1, 2.5, 3});
    EXPECT_EQ(in.point, (Vec3d{1, 4, 3}));
    EXPECT_EQ(in.distance, 1.5);
    const ClosestPoint centre = closest_point_on_sphere(s, {1, 2, 3});
    EXPECT_EQ(centre.point, (Vec3d{3, 2, 3}));
    EXPECT_EQ(centre.distance, 2.0);
    // A point on the surface along a diagonal: within the bound.
    const Vec3d d = normalize(Vec3d{1, 1, 1});
    const ClosestPoint on = closest_point_on_sphere(s, s.center + d * 2.0);
    EXPECT_LE(on.distance, on.err);
    EXPECT_EQ(closest_point_on_sphere(s, {1e12, 2, 3}).distance, 1e12 - 1 - 2);
}

PointHit hit(double d, std::uint32_t object, std::uint32_t prim, double err = 1e-15) {
    PointHit h;
    h.distance = d;
    h.err = err;
    h.object = object;
    h.primitive = prim;
    return h;
}

TEST(PointCandidates, TiesGoToTheLowerObjectThenPrimitiveInAnyOrder) {
    std::vector<PointHit> hits = {hit(1.0, 2, 0), hit(1.0 + 1e-16, 1, 5), hit(1.0, 1, 7),
                                  hit(0.9999999999999999, 3, 1), hit(1.5, 0, 0)};
    std::sort(hits.begin(), hits.end(), [](auto& a, auto& b) { return a.object < b.object; });
    do {
        PointCandidates c(0.0);
        for (const PointHit& h : hits)
            c.offer(h);
        EXPECT_EQ(c.winner().object, 1u);
        EXPECT_EQ(c.winner().primitive, 5u);
    } while (std::next_permutation(hits.begin(), hits.end(),
                                   [](auto& a, auto& b) { return a.object < b.object; }));
    PointCandidates clear(0.0);
    clear.offer(hit(2.0, 0, 0));
    clear.offer(hit(1.0, 4, 4));  // closer by far more than the bounds: wins whatever its ids
    EXPECT_EQ(clear.winner().object, 4u);
    EXPECT_FALSE(PointCandidates(0.0).winner().valid());
}

// The case found in review: H < A < B by ids, A closer than H by more than their small bounds, B
// closer still with a bound so large that H ties with it. By the API's rule
// the lowest ids among the candidates that tie with the closest (B) win: H. With the bound E on
// every candidate's err given, every order of the three gives H; with none (0), A, H, B gave A.
TEST(PointCandidates, TheWinnerDoesNotDependOnTheOrder) {
    PointHit h = hit(1.0, 0, 1), a = hit(1.0 - 1e-12, 0, 2), b = hit(1.0 - 2e-12, 0, 3);
    h.err = a.err = 1e-15;
    b.err = 1e-11;
    ASSERT_TRUE(h.distance <= b.distance + b.err + h.err);   // H ties with B
    ASSERT_FALSE(h.distance <= a.distance + a.err + h.err);  // but not with A
    std::vector<PointHit> order = {h, a, b};
    auto by_id = [](const PointHit& x, const PointHit& y) { return x.primitive < y.primitive; };
    int orders = 0;
    do {
        PointCandidates c(b.err);
        for (const PointHit& x : order)
            c.offer(x);
        EXPECT_EQ(c.winner().primitive, 1u)
            << "order " << order[0].primitive << order[1].primitive << order[2].primitive;
        ++orders;
    } while (std::next_permutation(order.begin(), order.end(), by_id));
    EXPECT_EQ(orders, 6);
    // Without E the review's order still loses H (what the bound is for).
    PointCandidates none(0.0);
    for (const PointHit& x : {a, h, b})
        none.offer(x);
    EXPECT_EQ(none.winner().primitive, 2u);
}

// From the review of the fix above: with E wider than the candidates' own bounds, more than kKeep
// of them may be kept that do not tie in the end; when the buffer dropped the highest ids to make
// room, X (which ties with B and has the lower id) was lost in one order and not in the other.
TEST(PointCandidates, AFullBufferLosesNoTie) {
    std::vector<PointHit> all = {hit(1.0, 0, 17), hit(1.0 + 1e-15, 0, 16)};
    for (std::uint32_t i = 1; i <= 15; ++i)
        all.push_back(hit(1.0 + 5e-10, 0, i));
    std::vector<PointHit> order = all;  // B, X, L1..L15
    std::mt19937 rng(18);
    for (int run = 0; run < 40; ++run) {
        PointCandidates c(1e-9);
        for (const PointHit& x : order)
            c.offer(x);
        EXPECT_EQ(c.winner().primitive, 16u) << "run " << run;
        if (run == 0)
            std::rotate(order.begin(), order.begin() + 1, order.end());  // X, L1..L15, B
        else
            std::shuffle(order.begin(), order.end(), rng);
    }
}

TEST(PointCandidates, CullDistanceCoversTheBound) {
    PointCandidates c(1e-9);
    EXPECT_EQ(c.cull_distance(), kInfinity);
    PointHit x = hit(1.0, 0, 0);
    x.err = 1e-15;
    c.offer(x);
    EXPECT_GE(c.cull_distance(), 1.0 + 4e-9);
}

TEST(PointCandidates, TheErrBoundCoversEveryPrimitive) {
    // A scene of a far sphere and a near triangle; the bound from its bounds covers both errs.
    const Sphere far{{1e6, -3e5, 2.0}, 7.5};
    const Triangle tri{{0.1, 0.2, 0.3}, {1.0, 0.0, 0.0}, {0.0, 1.0, 0.5}};
    Bounds3 scene;
    scene.extend(far.center - Vec3d{far.radius, far.radius, far.radius});
    scene.extend(far.center + Vec3d{far.radius, far.radius, far.radius});
    for (const Vec3d& v : {tri.a, tri.b, tri.c})
        scene.extend(v);
    for (const Vec3d& p : {Vec3d{0, 0, 0}, Vec3d{-4e7, 1, 1}, Vec3d{1e6, -3e5, 2.0}}) {
        const double e = candidate_err_bound(p, scene);
        EXPECT_GE(e, closest_point_on_sphere(far, p).err);
        EXPECT_GE(e, closest_point_on_triangle(tri, p)->err);
        EXPECT_LE(e, 4.0 * closest_point_on_sphere(far, p).err);  // not needlessly large
    }
}

TEST(PointCandidates, ManyTiesKeepTheLowestIds) {
    // A fan's apex: 100 primitives at exactly the same distance, offered highest id first.
    PointCandidates c(0.0);
    for (std::uint32_t i = 100; i-- > 0;)
        c.offer(hit(1.0, 0, i));
    EXPECT_EQ(c.winner().primitive, 0u);
    PointCandidates d(0.0);
    for (std::uint32_t i = 0; i < 100; ++i)
        d.offer(hit(1.0, 0, i));
    d.offer(hit(0.5, 9, 9));
    EXPECT_EQ(d.winner().object, 9u);
}

}  // namespace
}  // namespace raycastd::engine
