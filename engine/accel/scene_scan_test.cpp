// SceneScan: at exact, linear_closest's and linear_any's answers bit for bit (ties included);
// at fast, the same surfaces within the fast kernels' bounds.

#include "engine/accel/scene_scan.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <limits>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "engine/accel/linear_accel.h"
#include "engine/math/float_bounds.h"
#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

using testing::mesh_object;
using testing::sphere;

/// Spheres, a floor of two triangles, a cube (12 triangles sharing edges and vertices) and
/// exact twins: a sphere and a one-triangle mesh repeated as later objects (ties across
/// objects), and a mesh with a triangle repeated (a tie within one). 16 primitives.
Scene tie_scene() {
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(sphere("a", {0.5, 1, 4}, 1.0, 0));
    s.objects.push_back(mesh_object("floor", {{-9, 0, -9}, {-9, 0, 9}, {9, 0, -9}, {9, 0, 9}},
                                    {{0, 1, 2}, {2, 1, 3}}));
    s.objects.push_back(sphere("a twin", {0.5, 1, 4}, 1.0, 0));
    s.objects.push_back(
        mesh_object("tri", {{-3, 0.5, 6}, {-1, 0.5, 6}, {-2, 2.5, 6}}, {{0, 1, 2}}));
    s.objects.push_back(
        mesh_object("tri twin", {{-3, 0.5, 6}, {-1, 0.5, 6}, {-2, 2.5, 6}}, {{0, 1, 2}}));
    // The cube [1.5, 2.5]³ less two faces' triangles, and with one triangle listed twice: 16
    // primitives in all.
    const Object cube = testing::cube_object(1.5, 2.5);
    std::vector<std::array<std::uint32_t, 3>> t(cube.mesh->triangles.begin(),
                                                cube.mesh->triangles.begin() + 10);
    t.push_back(t[1]);  // z = 1.5, the face the rays meet
    s.objects.push_back(mesh_object("cube", cube.mesh->positions, std::move(t)));
    return s;
}

/// Rays from the eye's side aimed at the objects, their vertices and their edges (exact ties
/// of shared edges and of the twins), some with a short or raised segment.
std::vector<Ray> aimed_rays(const Scene& s, std::uint64_t seed, int n) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0), pos(-6.0, 6.0);
    std::vector<Vec3d> targets;
    for (const Object& o : s.objects) {
        if (o.kind == ObjectKind::sphere) {
            targets.push_back(o.sphere.center);
            targets.push_back(o.sphere.center + Vec3d{o.sphere.radius, 0, 0});
            continue;
        }
        for (std::size_t p = 0; p < o.mesh->size(); ++p) {
            const Triangle t = o.mesh->triangle(p);
            targets.insert(targets.end(), {t.a, t.b, (t.a + t.b) * 0.5, (t.a + t.b + t.c) / 3.0});
        }
    }
    std::vector<Ray> rays;
    for (int i = 0; i < n; ++i) {
        Ray r;
        r.origin = {pos(rng), 3.0 + pos(rng) * 0.5, -6.0 + pos(rng) * 0.3};
        const Vec3d target = i % 3 == 0 ? Vec3d{pos(rng), pos(rng) * 0.5, 6.0 + pos(rng)}
                                        : targets[rng() % targets.size()];
        r.direction = target - r.origin;
        if (i % 7 == 0)
            r.tmax = unit(rng) * 1.2;
        if (i % 11 == 0)
            r.tmin = unit(rng) * 0.9;
        rays.push_back(r);
    }
    return rays;
}

void expect_identical(const Hit& got, const Hit& want, std::size_t i) {
    EXPECT_EQ(got.object, want.object) << i;
    EXPECT_EQ(got.primitive, want.primitive) << i;
    EXPECT_EQ(got.t, want.t) << i;
    EXPECT_EQ(got.t_err, want.t_err) << i;
    EXPECT_EQ(got.u, want.u) << i;
    EXPECT_EQ(got.v, want.v) << i;
    EXPECT_EQ(got.normal, want.normal) << i;
    EXPECT_EQ(got.front_face, want.front_face) << i;
    EXPECT_EQ(got.on_edge, want.on_edge) << i;
}

/// The scan's closest (asked with each of `normals`) and any on `ray` against linear_closest
/// and linear_any on `s`, bit for bit; `where` names the ray in a failure.
void expect_as_linear_scan(const SceneScan& scan, const Scene& s, const Ray& ray,
                           std::initializer_list<bool> normals, const std::string& where) {
    for (const bool want_normal : normals) {
        const auto want = linear_closest(s, ray, want_normal);
        const auto got = scan.closest(ray, want_normal);
        ASSERT_EQ(got.has_value(), want.has_value()) << where;
        if (got) {
            SCOPED_TRACE(where);
            expect_identical(*got, *want, 0);
        }
    }
    EXPECT_EQ(scan.any(ray), linear_any(s, ray)) << where;
}

/// `count` one-triangle meshes added to `s`, their corners drawn within `scale` of the origin
/// on every axis (a corner may be up to twice that away).
void add_random_triangles(Scene& s, std::mt19937_64& rng, double scale, int count) {
    std::uniform_real_distribution<double> dir(-1.0, 1.0);
    const auto random_point = [&] { return Vec3d{dir(rng), dir(rng), dir(rng)} * scale; };
    for (int i = 0; i < count; ++i) {
        const Vec3d a = random_point();
        const Vec3d b = a + random_point();
        const Vec3d c = a + random_point();
        s.objects.push_back(mesh_object("t" + std::to_string(i), {a, b, c}, {{0, 1, 2}}));
    }
}

TEST(SceneScan, ExactIsTheLinearScanBitForBit) {
    const Scene s = tie_scene();
    const SceneScan scan(s, /*fast=*/false);
    const std::vector<Ray> rays = aimed_rays(s, 5, 6000);
    int hits = 0, twins = 0, on_edge = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        expect_as_linear_scan(scan, s, rays[i], {true, false}, std::to_string(i));
        if (const auto h = linear_closest(s, rays[i], false)) {
            ++hits;
            twins += h->object == 0 || h->object == 3;  // a twin later in the list ties with it
            on_edge += h->on_edge;
        }
    }
    // The rays reach what the test is about: the twins' ties and shared edges.
    EXPECT_GT(hits, 3000);
    EXPECT_GT(twins, 300);
    EXPECT_GT(on_edge, 100);
}

// Rays that start on a surface, as a render's shadow and reflected rays do (origins on tilted
// triangles' planes to within rounding, on either side or on it, directions off it at every
// angle and some within it): the scan's shortcut for a ray leaving a triangle's plane must skip
// only what the exact kernel misses. Fails when that shortcut ignores its rounding bounds.
TEST(SceneScan, RaysLeavingSurfacesAsTheLinearScan) {
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(sphere("ball", {0.3, 1.2, 4.1}, 0.9, 0));
    s.objects.push_back(
        mesh_object("tilted floor",
                    {{-7.1, -0.3, -6.7}, {-6.9, 0.45, 7.3}, {7.2, -0.61, -7.05}, {6.8, 0.2, 6.9}},
                    {{0, 1, 2}, {2, 1, 3}}));
    std::mt19937_64 rng(41);
    std::uniform_real_distribution<double> unit(0.0, 1.0), dir(-1.0, 1.0);
    for (int i = 0; i < 10; ++i) {
        const Vec3d a{dir(rng) * 4, dir(rng) * 2 + 1, dir(rng) * 4 + 3};
        s.objects.push_back(mesh_object("t" + std::to_string(i),
                                        {a, a + Vec3d{dir(rng), dir(rng), dir(rng)} * 1.5,
                                         a + Vec3d{dir(rng), dir(rng), dir(rng)} * 1.5},
                                        {{0, 1, 2}}));
    }
    const SceneScan exact(s, /*fast=*/false);
    int hits = 0, near_start = 0, left_behind = 0;
    for (std::size_t obj = 1; obj < s.objects.size(); ++obj) {
        const TriangleMesh& mesh = *s.objects[obj].mesh;
        for (std::size_t p = 0; p < mesh.size(); ++p) {
            const Triangle t = mesh.triangle(p);
            const TrianglePlane plane = TrianglePlane::of(t);
            const Vec3d n = normalize(cross(t.b - t.a, t.c - t.a));
            for (int k = 0; k < 300; ++k) {
                const double u = unit(rng), v = unit(rng) * (1.0 - u);
                Ray ray;
                ray.origin = t.a + (t.b - t.a) * u + (t.c - t.a) * v;  // on the plane, rounded
                ray.direction = Vec3d{dir(rng), dir(rng), dir(rng)};
                if (k % 5 == 0)  // nearly or exactly within the plane
                    ray.direction =
                        ray.direction - n * dot(ray.direction, n) * (k % 10 ? 1.0 : 0.999);
                if (k % 7 == 0)
                    ray.origin = ray.origin + n * (k % 2 ? 1e-13 : -1e-13);
                expect_as_linear_scan(
                    exact, s, ray, {true, false},
                    std::to_string(obj) + " " + std::to_string(p) + " " + std::to_string(k));
                if (plane.left_behind(ray, t.a)) {
                    ++left_behind;
                    EXPECT_FALSE(intersect_triangle(t, ray)) << obj << " " << p << " " << k;
                    EXPECT_FALSE(intersect_triangle_fast(t, ray)) << obj << " " << p << " " << k;
                }
                if (const auto h = linear_closest(s, ray, false)) {
                    ++hits;
                    near_start += h->t < 1e-9;
                }
            }
        }
    }
    EXPECT_GT(hits, 1000);
    EXPECT_GT(near_start, 50);    // rays that find the very surface they start on
    EXPECT_GT(left_behind, 150);  // the shortcut taken: rays 1e-13 off the plane, leaving it
}

// The scan's second shortcut: a plane crossed ahead but beyond tmax. Rays aimed at random
// triangles of five scales from a few sizes away, their tmax set a little below the exact
// kernel's t (by multiples of 2⁻⁴⁰ of t, of t_err, and by ulps), then just below, at and just
// above it for the comparison with the linear scan: wherever the plane says missed, the exact
// kernel and decide_triangle miss too, the fast kernel's sheared t, if it hits, is within its t_err
// of the exact t, and the scan misses at both precisions; and the scan at exact stays the
// linear scan bit for bit. Fails when the crossing is compared as computed, without s_bound,
// sd_bound and the factor; s_bound alone (~10u of the terms) is already wider than plane_t's
// error, so dropping the factor alone is not caught. At 1e-120 and 1e150 the plane's products
// underflow below 2⁻¹⁰⁰⁰ or overflow, and the test leaves every ray to the kernels: the rays
// passed over come from the three scales between.
TEST(SceneScan, CrossingsBeyondTmaxAreTheKernelsMisses) {
    std::mt19937_64 rng(2026);
    std::uniform_real_distribution<double> unit(0.0, 1.0), dir(-1.0, 1.0);
    int missed = 0, close = 0;
    for (const double scale : {1e-120, 1e-3, 1.0, 1e5, 1e150}) {
        Scene s;
        s.materials.push_back(Material{});
        add_random_triangles(s, rng, scale, 8);
        const SceneScan scan(s, false);
        for (int k = 0; k < 6000; ++k) {
            const Triangle t = s.objects[k % 8].mesh->triangle(0);
            const TrianglePlane plane = TrianglePlane::of(t);
            const double u = unit(rng), v = unit(rng) * (1.0 - u);
            const Vec3d target = t.a + (t.b - t.a) * u + (t.c - t.a) * v;
            Ray r;
            r.origin = target + Vec3d{dir(rng), dir(rng), dir(rng)} * (scale * (1 + 4 * unit(rng)));
            r.direction = (target - r.origin) * (k % 3 == 0 ? 1.0 : 1.0 / (scale * (k % 5 + 1)));
            const auto h = intersect_triangle(t, r);
            if (!h)
                continue;
            // tmax from below t by a few times the factor's 2⁻⁴⁰, by t_err, and by ulps.
            const double below[] = {4.0, 2.0, 1.0, 0.5};
            const double steps[] = {-2.0, -1.0, -0.5, 0.0};
            for (int j = 0; j < 16; ++j) {
                Ray q = r;
                if (j < 4)
                    q.tmax = h->t - below[j] * h->t * 0x1p-40;
                else if (j < 8)
                    q.tmax = h->t + steps[j - 4] * h->t_err;
                else
                    q.tmax = std::nextafter(h->t, 0.0) * (1.0 - (j - 8) * 0x1p-50);
                q.tmax = std::max(q.tmax, 0.0);
                if (!plane.missed(q, t.a))
                    continue;
                ++missed;
                close += q.tmax > h->t * (1.0 - 0x1p-36);
                EXPECT_FALSE(intersect_triangle(t, q)) << scale << " " << k << " " << j;
                EXPECT_FALSE(decide_triangle(t, q)) << scale << " " << k << " " << j;
                if (const auto f = intersect_triangle_fast(t, q)) {
                    EXPECT_GE(f->t + f->t_err, h->t - h->t_err) << scale << " " << k << " " << j;
                }
                Scene one;
                one.materials.push_back(Material{});
                one.objects.push_back(s.objects[k % 8]);
                for (const bool fast : {false, true}) {
                    EXPECT_FALSE(SceneScan(one, fast).closest(q, false)) << scale << " " << k;
                    EXPECT_FALSE(SceneScan(one, fast).any(q)) << scale << " " << k;
                }
            }
            for (const double f : {0.999, 1.0, 1.001}) {
                Ray q = r;
                q.tmax = h->t * f;
                expect_as_linear_scan(scan, s, q, {true},
                                      std::to_string(scale) + " " + std::to_string(k));
            }
        }
    }
    EXPECT_GT(missed, 30000);
    EXPECT_GT(close, 25000);  // within 2⁻³⁶ of the crossing: the margin itself is tested
}

// Where plane_t's numerator is below its double-double resolution it rounds to 0 and the exact
// kernel reports t = 0: an origin 1e-33 off a triangle through the world origin (a helper's
// case), and scenes at 2⁻³⁵⁵ (~1e-107), where the normal's products underflow. The shortcut
// must leave all of them to the kernels.
TEST(SceneScan, OriginsWithinTheKernelsResolutionAreLeftToThem) {
    const Triangle tri{{0, 0, 0}, {0, 3, 0}, {0.9, 1, 0.9}};
    const Ray ray{{1e-33, 1, 0}, {1, 0.1, -0.5}};
    EXPECT_FALSE(TrianglePlane::of(tri).left_behind(ray, tri.a));
    Scene one;
    one.materials.push_back(Material{});
    one.objects.push_back(mesh_object("t", {tri.a, tri.b, tri.c}, {{0, 1, 2}}));
    const auto want = linear_closest(one, ray, true);
    const auto got = SceneScan(one, false).closest(ray, true);
    ASSERT_EQ(got.has_value(), want.has_value());
    if (got)
        expect_identical(*got, *want, 0);

    // A normal whose products underflow is never used; a zero edge component is exact.
    EXPECT_FALSE(TrianglePlane::of(Triangle{{0, 0, 0}, {1e-200, 1, 0}, {0, 1e-200, 1}}).usable);
    EXPECT_TRUE(TrianglePlane::of(Triangle{{0, 0, 0}, {1, 0, 0}, {0, 0, 1}}).usable);

    std::mt19937_64 rng(355);
    std::uniform_real_distribution<double> unit(0.0, 1.0), dir(-1.0, 1.0);
    for (const double scale : {0x1p-355, 0x1p-500, 1.0}) {
        Scene s;
        s.materials.push_back(Material{});
        add_random_triangles(s, rng, scale, 12);
        const SceneScan scan(s, false);
        int hits = 0;
        for (int k = 0; k < 4000; ++k) {
            const Triangle t = s.objects[k % 12].mesh->triangle(0);
            const double u = unit(rng), v = unit(rng) * (1.0 - u);
            const Ray r{t.a + (t.b - t.a) * u + (t.c - t.a) * v,
                        Vec3d{dir(rng), dir(rng), dir(rng)}};
            expect_as_linear_scan(scan, s, r, {false},
                                  std::to_string(scale) + " " + std::to_string(k));
            hits += linear_closest(s, r, false).has_value();
        }
        EXPECT_GT(hits, 100) << scale;
    }
}

// A triangle 1e100 across seen from 1e108: n·(o − a) overflows to +inf though its true value is
// about −1e308 (a product rounds to +inf, the others are huge and negative). The shortcut's
// bound, its factors summed once per triangle, stays finite there: it took the plane for left
// behind and the scan missed a triangle the kernels hit (a helper's probe). An overflowed dot
// product is left to the kernels.
TEST(SceneScan, OverflowedPlaneProductsAreLeftToTheKernels) {
    const double L = 1e100;
    const Triangle tri{{0, 0, 0}, {L, L, 0}, {L, 0, L}};
    Ray ray;
    ray.origin = Vec3d{1.85e108, 1.5e108, 1.5e108};
    ray.direction = normalize(Vec3d{2 * L / 3, L / 3, L / 3} - ray.origin);
    EXPECT_FALSE(std::isfinite(dot(TrianglePlane::of(tri).n, ray.origin - tri.a)));
    EXPECT_FALSE(TrianglePlane::of(tri).left_behind(ray, tri.a));
    Scene one;
    one.materials.push_back(Material{});
    one.objects.push_back(mesh_object("t", {tri.a, tri.b, tri.c}, {{0, 1, 2}}));
    const auto want = linear_closest(one, ray, true);
    ASSERT_TRUE(want.has_value());
    const auto got = SceneScan(one, false).closest(ray, true);
    ASSERT_TRUE(got.has_value());
    expect_identical(*got, *want, 0);
    EXPECT_TRUE(SceneScan(one, false).any(ray));
    EXPECT_TRUE(SceneScan(one, true).closest(ray, false).has_value());
    EXPECT_TRUE(SceneScan(one, true).any(ray));
}

// The scan at exact is the linear scan bit for bit at every scale where its shortcut and kept
// normals might part from the kernels: triangles and spheres from 1e-280 to 1e250 across, seen
// from 1 to 3e9 of their sizes away, where the plane products underflow or overflow and the
// kernels rescale (the two defects above were found at such scales by a helper's probes).
TEST(SceneScan, ExactIsTheLinearScanAtEveryScale) {
    std::mt19937_64 rng(280);
    std::uniform_real_distribution<double> unit(0.0, 1.0), dir(-1.0, 1.0);
    int hits = 0, rays = 0;
    for (const double scale : {1e-280, 1e-150, 1e-100, 1e-30, 1e30, 1e100, 1e150, 1e250}) {
        Scene s;
        s.materials.push_back(Material{});
        add_random_triangles(s, rng, scale, 10);
        s.objects.push_back(
            sphere("s0", Vec3d{dir(rng), dir(rng), dir(rng)} * scale, 0.3 * scale, 0));
        s.objects.push_back(
            sphere("s1", Vec3d{dir(rng), dir(rng), dir(rng)} * scale, 0.2 * scale, 0));
        const SceneScan scan(s, /*fast=*/false);
        for (const double away : {1.0, 1e4, 1e8, 3e8, 1e9, 3e9}) {
            for (int k = 0; k < 300; ++k) {
                const Triangle t = s.objects[k % 10].mesh->triangle(0);
                const double u = unit(rng), v = unit(rng) * (1.0 - u);
                const Vec3d target = t.a + (t.b - t.a) * u + (t.c - t.a) * v;
                Ray r;
                r.origin = target + normalize(Vec3d{dir(rng), dir(rng), dir(rng)}) * (away * scale);
                r.direction = (target - r.origin) * (k % 3 == 0 ? 1.0 / scale : 1.0);
                expect_as_linear_scan(scan, s, r, {true, false},
                                      "scale " + std::to_string(scale) + " away " +
                                          std::to_string(away) + " ray " + std::to_string(k));
                hits += linear_any(s, r);
                ++rays;
            }
        }
    }
    EXPECT_GT(hits, rays * 8 / 10);  // aimed at triangles: most rays hit something
}

TEST(SceneScan, FastFindsTheSameSurfacesWithinItsBounds) {
    const Scene s = tie_scene();
    const SceneScan scan(s, /*fast=*/true);
    const std::vector<Ray> rays = aimed_rays(s, 6, 6000);
    int agree = 0, hits = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        const auto want = linear_closest(s, rays[i], true);
        const auto got = scan.closest(rays[i], true);
        // A ray aimed at an edge or a silhouette may go either way within the bounds; where
        // both hit, the answers are within both bounds of each other.
        if (got.has_value() == want.has_value())
            ++agree;
        if (!got || !want)
            continue;
        ++hits;
        EXPECT_LE(std::abs(got->t - want->t), got->t_err + want->t_err) << i;
        EXPECT_GT(got->t_err, 0.0) << i;
        EXPECT_EQ(dot(got->normal, got->normal) > 0.5, true) << i;
        EXPECT_EQ(scan.any(rays[i]), true) << i;
    }
    EXPECT_GE(agree, static_cast<int>(rays.size()) - 30);
    EXPECT_GT(hits, 3000);
}

/// A sphere's kernel answer as the scan must give it: the first root in range.
std::optional<Hit> kernel_hit(const Sphere& s, const Ray& r, bool fast) {
    return first_hit_of_roots(s, r, fast ? sphere_roots_fast(s, r) : sphere_roots(s, r), true);
}

/// The rule of SceneScan::sphere_candidates for one sphere, written out in scalar arithmetic in
/// the scan's own order (the scan runs it in vector lanes): whether it rules `s` out for `r`.
/// Compared bit by bit with the scan's lanes, so that a lane read or reported for the wrong
/// sphere shows, whichever sphere the rays were aimed at.
bool rule_rules_out(const Sphere& s, const Ray& r) {
    constexpr double u = kDoubleUnitRoundoff;
    constexpr double kMax = std::numeric_limits<double>::max();
    const double r2 = s.radius * s.radius;
    if (!(r2 >= 0x1p-1000 && r2 <= 0x1p1000))
        return false;  // not cullable: the kernels decide
    const Vec3d& d = r.direction;
    const double a = d.x * d.x + d.y * d.y + d.z * d.z;
    const double fx = r.origin.x - s.center.x, fy = r.origin.y - s.center.y,
                 fz = r.origin.z - s.center.z;
    const double ff = fx * fx + fy * fy + fz * fz;
    const double beta = fx * d.x + fy * d.y + fz * d.z;
    const double fa = ff * a;
    const double cc = fa - beta * beta;  // |f × d|² by Lagrange's identity
    const double ar2 = a * r2;
    const double bound = 128.0 * u * (fa + ar2) + 0x1p-900;
    bool out = ar2 - cc < -bound && bound <= kMax && cc <= kMax && a >= 0x1p-1020;
    if (r.tmin >= 0.0) {
        out = out || (ff - r2 > 8.0 * u * (ff + r2) && beta > 0.0 &&
                      beta * beta > 64.0 * u * u * fa + 0x1p-900 && fa <= kMax && ff <= kMax);
    }
    return out;
}

TEST(SceneScan, SpheresRuledOutBeforeTheKernelAreTheKernelsMisses) {
    // The scan rules spheres out four (AVX) or two (SSE2) at a time before calling a kernel
    // (lines that miss by more than the rounding, spheres behind an origin outside them). Rays
    // are made to sit on those boundaries: lines passing at r·(1 ± ε) from the centre, origins
    // at r·(1 ± ε) from it moving away or towards, over scales and offsets where the bounds'
    // terms change size, and with tmin below, at and above 0. Five spheres, so that a full quad
    // and a lone lane are both used; the rays are aimed at the second (lane 1 of the first
    // quad), the fourth (lane 3: the second pair's lane 1 in SSE2) or the fifth (lane 0 of the
    // second quad), and each must get the kernel's own answer, with the same candidates in
    // either lanes.
    const bool four_lanes = SceneScan::widest_lanes() == SceneScan::Lanes::four;
    if (!four_lanes)
        std::printf("this processor has no AVX: only the two-lane rule is tested\n");
    std::mt19937_64 rng(20261204);
    std::uniform_real_distribution<double> dir(-1.0, 1.0);
    // 128u of the bound is ~1.5e-13 of r² for the lines below (|f|² ≈ 10r²): 3e-14 to 3e-13
    // bracket it.
    const double eps[] = {0.0,   1e-17, 1e-16, 4e-16, 1e-15, 1e-14,
                          3e-14, 1e-13, 3e-13, 1e-12, 1e-8,  1e-3};
    constexpr int kEps = sizeof eps / sizeof eps[0];
    int checked = 0, hits = 0, misses = 0, ruled_out = 0;
    // r² within [2⁻¹⁰⁰⁰, 2¹⁰⁰⁰] is ruled on (1e±150 near its ends); 1e±160 and 1e-300 go to the
    // kernel always.
    for (const double radius : {1.0, 1e-3, 1e8, 1e-150, 1e150, 1e-160, 1e160, 1e-300}) {
        for (const double offset : {0.0, 1e6, 1e12, -1e15}) {
            const Vec3d c{offset + 0.3 * radius, offset - 0.7 * radius, offset + 0.1 * radius};
            // The others well apart from it, also where the radius is below the offset's ulp.
            const double apart = 1e3 * std::max(radius, 1e-9 * std::abs(offset));
            Scene s;
            s.materials.push_back(Material{});
            s.objects.push_back(sphere("far", c + Vec3d{1e6, 1e6, 1e6} * apart, radius, 0));
            s.objects.push_back(sphere("aimed", c, radius, 0));
            s.objects.push_back(sphere("far too", c - Vec3d{1e6, 1e6, 1e6} * apart, radius, 0));
            s.objects.push_back(
                sphere("aimed too", c - Vec3d{0.05, 0.05, 0.05} * apart, radius, 0));
            s.objects.push_back(
                sphere("aimed third", c + Vec3d{0.05, -0.05, 0.05} * apart, radius, 0));
            for (const bool fast : {false, true}) {
                const SceneScan scan(s, fast);
                for (int k = 0; k < 720; ++k) {
                    // k's digits: the ray's kind (k % 4, below), then ε, then the aimed sphere,
                    // then ε's sign, so that every aimed sphere meets every ε on every kind.
                    const int e_index = k / 4 % kEps;
                    const std::uint32_t aim =
                        std::array<std::uint32_t, 3>{1, 3, 4}[k / (4 * kEps) % 3];
                    const Vec3d& ac = s.objects[aim].sphere.center;
                    const Vec3d unit = normalize(Vec3d{dir(rng), dir(rng), dir(rng)});
                    // Lengths from 3e-162 (d·d subnormal: its rounding is no longer relative),
                    // either side of the rule's 2⁻¹⁰²⁰ on d·d (2e-154, 4e-154), to 7e2.
                    const double lengths[] = {1e-3, 1.0, 7e2, 1e-160, 3e-162, 2e-154, 4e-154};
                    const Vec3d d = unit * lengths[(k / 7) % 7];
                    // A unit vector across the direction.
                    Vec3d w = cross(unit, Vec3d{dir(rng), dir(rng), dir(rng)});
                    w = w / length(w);
                    const double e = eps[e_index] * (k / (12 * kEps) % 2 ? 1.0 : -1.0);
                    Ray r;
                    if (k % 4 < 2) {
                        // The line passes at r(1 + e) from the centre, the origin 3r before or
                        // 2r after the closest approach.
                        const double along = (k % 4 == 0 ? -3.0 : 2.0) * radius;
                        r = Ray{ac + w * (radius * (1 + e)) + unit * along, d};
                    } else {
                        // The origin r(1 + e) from the centre, moving away from it or towards.
                        const Vec3d out = k % 4 == 2 ? unit : -unit;
                        const Vec3d u = normalize(out * 0.8 + w * 0.6);
                        r = Ray{ac + u * (radius * (1 + e)), d};
                    }
                    r.tmin = k % 5 == 0 ? -2.0 : k % 5 == 1 ? 1e-9 : 0.0;
                    const auto want = kernel_hit(s.objects[aim].sphere, r, fast);
                    const auto got = scan.closest(r, true);
                    const std::uint32_t candidates = scan.sphere_candidates(r);
                    EXPECT_EQ(candidates, scan.sphere_candidates(r, SceneScan::Lanes::two));
                    if (four_lanes) {
                        EXPECT_EQ(candidates, scan.sphere_candidates(r, SceneScan::Lanes::four));
                    }
                    for (std::uint32_t j = 0; j < s.objects.size(); ++j) {
                        EXPECT_EQ(!SceneScan::may_hit(candidates, j),
                                  rule_rules_out(s.objects[j].sphere, r))
                            << "sphere " << j << " " << radius << " " << offset << " " << k;
                    }
                    if (!SceneScan::may_hit(candidates, aim)) {
                        ++ruled_out;
                        EXPECT_FALSE(want.has_value())
                            << radius << " " << offset << " " << fast << " " << k;
                    }
                    const std::string where = std::to_string(radius) + " " +
                                              std::to_string(offset) + " " + std::to_string(fast) +
                                              " " + std::to_string(k);
                    // Where the scan answers with another sphere (one the ray meets before its
                    // origin, with tmin < 0), the aimed one's hit must not come first.
                    if (got && got->object != aim) {
                        if (want) {
                            EXPECT_TRUE(got->object < aim ? want->t >= got->t : want->t > got->t)
                                << where;
                        }
                        continue;
                    }
                    ASSERT_EQ(got.has_value(), want.has_value()) << where;
                    ++checked;
                    if (!got) {
                        ++misses;
                        EXPECT_FALSE(scan.any(r)) << where;
                        continue;
                    }
                    ++hits;
                    EXPECT_EQ(got->t, want->t) << where;
                    EXPECT_TRUE(scan.any(r)) << where;
                }
            }
        }
    }
    EXPECT_GT(hits, 3000);
    EXPECT_GT(misses, 3000);
    EXPECT_GT(checked, 20000);
    EXPECT_GT(ruled_out, 2000);  // the rule itself at work, not only the kernels

    // A direction so short that d·d is a few subnormal steps (a helper's review): its rounding
    // is no longer relative, a·r² with r = 1e100 is off by a third, and the line, 0.85 r from
    // the centre and square to f (so the fast kernel's l = f whatever a is), had been ruled
    // out while sphere_roots_fast hits.
    Scene big;
    big.materials.push_back(Material{});
    big.objects.push_back(sphere("big", {0, 0, 0}, 1e100, 0));
    const double k = 1.2247 * 0x1p-537;
    const Ray grazing{{6e99, -6e99, 0}, {k, k, k}};
    ASSERT_TRUE(kernel_hit(big.objects[0].sphere, grazing, true).has_value());
    ASSERT_TRUE(kernel_hit(big.objects[0].sphere, grazing, false).has_value());
    EXPECT_TRUE(SceneScan(big, false).closest(grazing, true).has_value());
    EXPECT_TRUE(SceneScan::may_hit(SceneScan(big, true).sphere_candidates(grazing), 0));
    EXPECT_TRUE(SceneScan(big, true).closest(grazing, true).has_value());
    EXPECT_TRUE(SceneScan(big, true).any(grazing));
}

// The scan tests the spheres before the meshes, whatever the objects' order: a sphere and a
// triangle that a ray meets at exactly the same t (a plane tangent to the sphere where the ray
// touches it, t = 4 in both kernels) go to the lower object in both orders, as `closer` and
// linear_closest give them, at both precisions; rays beside that point are linear_closest's
// bit for bit at exact. Fails if a mesh's hit stops being compared with a sphere found before
// it, or if a sphere's normal is kept for a triangle that beat it.
TEST(SceneScan, TiesBetweenASphereAndAMeshGoToTheLowerObject) {
    const Object ball = sphere("ball", {0, 0, 0}, 1.0, 0);
    const Object wall = mesh_object("wall", {{-1, -4, -4}, {-1, 4, -4}, {-1, 0, 4}}, {{0, 1, 2}});
    for (const bool wall_first : {true, false}) {
        Scene s;
        s.materials.push_back(Material{});
        s.objects.push_back(wall_first ? wall : ball);
        s.objects.push_back(wall_first ? ball : wall);
        const Ray tie{{-5, 0, 0}, {1, 0, 0}};
        for (const bool fast : {false, true}) {
            const SceneScan scan(s, fast);
            const auto h = scan.closest(tie, true);
            ASSERT_TRUE(h.has_value()) << wall_first << fast;
            EXPECT_EQ(h->t, 4.0) << wall_first << fast;
            EXPECT_EQ(h->object, 0u) << wall_first << fast;
            // The wall's (b − a)×(c − a) is +x, the ball's outward normal there −x.
            EXPECT_EQ(h->normal, (Vec3d{wall_first ? 1.0 : -1.0, 0, 0})) << wall_first << fast;
            EXPECT_TRUE(scan.any(tie));
        }
        const SceneScan exact(s, /*fast=*/false);
        expect_as_linear_scan(exact, s, tie, {true, false}, "the tie");
        std::mt19937_64 rng(wall_first ? 3 : 4);
        std::uniform_real_distribution<double> off(-1.0, 1.0);
        for (int i = 0; i < 2000; ++i) {
            // Beside the point of contact by 1e-12 to 1e-1, and some through the ball.
            const double scale = std::pow(10.0, -1.0 - 11.0 * (i % 12) / 11.0);
            Ray r{{-5, off(rng) * scale, off(rng) * scale}, {1, off(rng) * scale, 0}};
            if (i % 5 == 0)
                r.origin.y += 0.5;
            expect_as_linear_scan(exact, s, r, {true, false}, std::to_string(i));
        }
    }
}

// At fast the order of the tests can matter, within fast's bounds: a grazing ray's fast t on a
// floor can come before the floor's exact crossing by more than a sphere's entry is from it.
// With the floor listed first, and a ball whose entry lies between the floor's fast t and its
// exact t, the scan (which tests spheres first, and then culls the floor by its exact
// crossing against the ball's t) answers within both answers' bounds of linear_closest at
// exact, and in most of these cases with exact's object, the ball. (A helper's review found
// the case; until 2026-12-07 the scan tested the floor first, took its early fast t and
// answered the floor in 1,835 of 2,000 such rays.)
TEST(SceneScan, FastNearTiesOfAMeshListedBeforeASphereStayWithinTheBounds) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    int cases = 0, as_exact = 0;
    for (int i = 0; i < 400000 && cases < 2000; ++i) {
        const double size = std::pow(10.0, 5 * unit(rng));
        const Vec3d a{-size, 0, -size}, b{-size, 0, 3 * size}, c{3 * size, 0, -size};
        const double grazing = std::pow(10.0, -8 * unit(rng));
        const double angle = unit(rng) * 6.28;
        const Ray ray{{(unit(rng) * 2 - 1) * size, std::pow(10.0, -6 + 6 * unit(rng)),
                       (unit(rng) * 2 - 1) * size},
                      {std::cos(angle), -grazing, std::sin(angle)}};
        const Triangle floor{a, b, c};
        const auto fast_t = intersect_triangle_fast(floor, ray, false);
        const auto exact_t = intersect_triangle(floor, ray, false);
        if (!fast_t || !exact_t || !(exact_t->t - fast_t->t > 1e-9 * exact_t->t))
            continue;
        ++cases;
        // A ball entered halfway between the two t.
        const double t = 0.5 * (fast_t->t + exact_t->t);
        const double radius = 1e-3 * t;
        const Vec3d unit_d = ray.direction / length(ray.direction);
        Scene s;
        s.materials.push_back(Material{});
        s.objects.push_back(mesh_object("floor", {a, b, c}, {{0, 1, 2}}));
        s.objects.push_back(
            sphere("ball", ray.origin + unit_d * (t * length(ray.direction) + radius), radius, 0));
        const auto got = SceneScan(s, /*fast=*/true).closest(ray, true);
        const auto want = linear_closest(s, ray, true);
        ASSERT_TRUE(got && want) << i;
        EXPECT_LE(std::abs(got->t - want->t), got->t_err + want->t_err) << i;
        as_exact += got->object == want->object;
    }
    EXPECT_GE(cases, 1000);
    EXPECT_GE(as_exact, cases * 8 / 10);
}

TEST(SceneScan, FortySpheresAreRuledOnUpToTheThirtySecond) {
    // Ten quads of spheres: the rule covers the first 32 (eight quads, bit k for sphere k) and
    // leaves the rest to the kernels. Rays from around and inside the cluster: every bit is the
    // scalar rule's, every sphere past the 32nd is a candidate, and the scan's answers at exact
    // are linear_closest's and linear_any's.
    Scene s;
    s.materials.push_back(Material{});
    for (int k = 0; k < 40; ++k) {
        const double x = (k % 5) * 2.5, y = (k / 5 % 4) * 2.5, z = (k / 20) * 2.5;
        s.objects.push_back(sphere("s" + std::to_string(k), {x, y, z}, 0.4 + 0.02 * k, 0));
    }
    const SceneScan scan(s, /*fast=*/false);
    std::mt19937_64 rng(40);
    std::uniform_real_distribution<double> pos(-3.0, 13.0), dir(-1.0, 1.0);
    int hits = 0, beyond = 0, ruled_out = 0;
    for (int i = 0; i < 4000; ++i) {
        Ray r{{pos(rng), pos(rng), pos(rng)}, {dir(rng), dir(rng), dir(rng)}};
        if (i % 2 == 1)  // aimed near a sphere's centre, every sphere in turn
            r.direction = s.objects[i / 2 % 40].sphere.center - r.origin +
                          Vec3d{dir(rng), dir(rng), dir(rng)} * 0.3;
        r.tmin = i % 3 == 0 ? -1.0 : 0.0;
        const std::uint32_t candidates = scan.sphere_candidates(r);
        for (std::uint32_t j = 0; j < 40; ++j) {
            const bool out = !SceneScan::may_hit(candidates, j);
            EXPECT_EQ(out, j < 32 && rule_rules_out(s.objects[j].sphere, r)) << i << " " << j;
            ruled_out += out;
        }
        const auto want = linear_closest(s, r, true);
        const auto got = scan.closest(r, true);
        ASSERT_EQ(got.has_value(), want.has_value()) << i;
        if (got) {
            expect_identical(*got, *want, static_cast<std::size_t>(i));
            ++hits;
            beyond += got->object >= 32;
        }
        EXPECT_EQ(scan.any(r), linear_any(s, r)) << i;
    }
    EXPECT_GT(hits, 1800);
    EXPECT_GT(beyond, 200);           // spheres past the 32nd are found
    EXPECT_GT(ruled_out, 4000 * 20);  // most of the first 32 are ruled out for most rays
}

}  // namespace
}  // namespace raycastd::engine
