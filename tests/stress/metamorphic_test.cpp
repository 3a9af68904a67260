// Metamorphic relations (issue 6): they hold whatever the truth is, so they need no reference.
// Transforms are chosen exact in binary floating point (dyadic coordinates, power-of-two
// scales, the 24 rotations of the cube), so that the transformed problem has the same exact
// answer and only the engine's own arithmetic can make the answers differ:
//   translate scene and rays together → t unchanged;
//   scale both (origins, positions, radii and directions) by s → t unchanged;
//   rotate both → hits unchanged;
//   reverse a ray from a point beyond its first hit → the same surface, at the same point;
//   scale the direction by k → t divided by k;
//   a line through a closed mesh crosses it an even number of times;
//   a batch answers as its rays asked one at a time (set up four at a time, or one by one).
// exact (and refined, for t) are asserted; fast is recorded.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <optional>
#include <random>

#include <gtest/gtest.h>

#include "engine/query/intersect.h"
#include "engine/testing/bits.h"
#include "engine/testing/scenes.h"
#include "tests/stress/case_file.h"
#include "tests/stress/generators.h"

namespace raycastd::stress {
namespace {

using engine::Hit;
using engine::Object;
using engine::ObjectKind;
using engine::Precision;
using engine::QueryEngine;
using engine::Ray;
using engine::Scene;
using engine::Vec3d;

/// A double on the grid 2^-20, in [-8, 8].
double dyadic(std::mt19937_64& rng) {
    return std::ldexp(std::uniform_int_distribution<long>(-(8L << 20), 8L << 20)(rng), -20);
}
Vec3d dyadic3(std::mt19937_64& rng) {
    return {dyadic(rng), dyadic(rng), dyadic(rng)};
}
Vec3d on_grid(const Vec3d& v) {
    return {std::ldexp(std::round(std::ldexp(v.x, 20)), -20),
            std::ldexp(std::round(std::ldexp(v.y, 20)), -20),
            std::ldexp(std::round(std::ldexp(v.z, 20)), -20)};
}

/// Spheres, triangles, a cube and an icosphere, every coordinate on the 2^-20 grid (the
/// icosphere's vertices are snapped to it; it stays closed: the vertices are shared).
Scene dyadic_scene(std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    Scene s = empty_scene();
    for (int k = 0; k < 4; ++k) {
        s.objects.push_back(sphere(dyadic3(rng), std::ldexp(1 + (rng() % 64), -5)));
    }
    for (int k = 0; k < 4; ++k) {
        const Vec3d a = dyadic3(rng);
        s.objects.push_back(
            triangle(a, on_grid(a + dyadic3(rng) * 0.25), on_grid(a + dyadic3(rng) * 0.25)));
    }
    s.objects.push_back(engine::testing::cube_object(-1.5, -0.5));
    Object ico = engine::testing::icosphere_object(3, {1, 1, 1}, 1.25);
    auto mesh = std::make_shared<engine::TriangleMesh>(*ico.mesh);
    for (auto& p : mesh->positions)
        p = on_grid(p);
    ico.mesh = mesh;
    s.objects.push_back(ico);
    return s;
}

std::vector<Ray> dyadic_rays(std::uint64_t seed, const Scene& s, int n) {
    std::mt19937_64 rng(seed);
    std::vector<Ray> rays;
    for (int i = 0; i < n; ++i) {
        const Object& o = s.objects[static_cast<std::size_t>(i) % s.objects.size()];
        const Vec3d target = o.kind == ObjectKind::sphere
                                 ? o.sphere.center
                                 : o.mesh->positions[0] * 0.5 + o.mesh->positions[1] * 0.25 +
                                       o.mesh->positions[2] * 0.25;
        const Vec3d origin = dyadic3(rng) * 2.0;
        Vec3d d = target - origin + dyadic3(rng) * 0.125;
        if (engine::length(d) < 1e-3)
            d = {1, 0, 0};
        rays.push_back(Ray{origin, d});
    }
    return rays;
}

std::shared_ptr<const QueryEngine> build(Scene s) {
    auto e = QueryEngine::build(std::make_shared<Scene>(std::move(s)));
    EXPECT_TRUE(e.ok());
    return *e;
}

std::vector<Hit> closest(const QueryEngine& e, const std::vector<Ray>& rays, Precision p) {
    engine::QueryOptions opt;
    opt.precision = p;
    return e.intersect(rays, opt).hits;
}

double ulps_apart(double a, double b) {
    return a == b ? 0.0 : std::abs(a - b) / ulp(std::max(std::abs(a), std::abs(b)));
}

/// Compares answers to the same problem before and after an exact transform: same hit/miss and
/// object everywhere, t (times `t_factor`) within `max_ulps` for exact and refined.
void expect_same(const std::string& what, const std::vector<Hit>& a, const std::vector<Hit>& b,
                 Precision p, double t_factor = 1.0, double max_ulps = 8.0) {
    std::size_t differ = 0;
    double worst = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        if (a[i].valid() != b[i].valid() || (a[i].valid() && a[i].object != b[i].object)) {
            ++differ;
            continue;
        }
        if (a[i].valid())
            worst = std::max(worst, ulps_apart(a[i].t, b[i].t * t_factor));
    }
    std::printf("[ metamorph] %-34s %-8s decisions differ %zu, t differs by ≤ %.3g ulps\n",
                what.c_str(), engine::to_string(p), differ, worst);
    ::testing::Test::RecordProperty(what + "." + engine::to_string(p) + ".max_ulps",
                                    std::to_string(worst));
    if (p == Precision::fast)
        return;
    EXPECT_EQ(differ, 0u) << what << " " << engine::to_string(p);
    EXPECT_LE(worst, max_ulps) << what << " " << engine::to_string(p);
}

const Precision kAll[] = {Precision::fast, Precision::refined, Precision::exact};

/// Applies `f` to every position, centre and ray origin and `g` to every direction and radius.
Scene map_scene(const Scene& s, const std::function<Vec3d(const Vec3d&)>& f, double radius_scale) {
    Scene out = s;
    for (Object& o : out.objects) {
        if (o.kind == ObjectKind::sphere) {
            o.sphere.center = f(o.sphere.center);
            o.sphere.radius *= radius_scale;
            continue;
        }
        auto mesh = std::make_shared<engine::TriangleMesh>(*o.mesh);
        for (auto& p : mesh->positions)
            p = f(p);
        o.mesh = mesh;
    }
    return out;
}

// A batch is set up sixteen rays at a time (refined's packets and exact's batches: lanes formed
// four at a time in AVX, embree/packets.h), a ray asked alone (QueryEngine::closest) by
// prepare_ray: exact's answers are
// the same bit for bit, refined's and fast's the same decisions and t within 8 ulps (a packet's
// float traversal may meet two near-tied candidates in another order). On the mixed dyadic
// scene and on a scene of meshes alone (the one refined traces in packets), with rays that take
// prepare_ray's other branches mixed in: a zero direction component, a far origin, a segment
// that stops short.
TEST(Metamorphic, BatchesAnswerAsSingleRays) {
    Scene meshes = empty_scene();
    meshes.objects.push_back(engine::testing::icosphere_object(4, {0.25, -0.5, 0.75}, 1.5));
    meshes.objects.push_back(engine::testing::cube_object(1.5, 2.5));
    for (const Scene& s : {dyadic_scene(27), meshes}) {
        std::vector<Ray> rays = dyadic_rays(28, s, 700);
        for (std::size_t i = 0; i < rays.size(); i += 7) {
            switch (i / 7 % 3) {
                case 0:
                    rays[i].direction.y = 0.0;
                    break;
                case 1:
                    rays[i].origin = rays[i].origin * 1e10;
                    rays[i].direction = rays[i].origin * -1.0;
                    break;
                default:
                    rays[i].tmax = 0.5;
                    break;
            }
        }
        const auto e = build(s);
        for (Precision p : kAll) {
            const std::vector<Hit> batch = closest(*e, rays, p);
            // One at a time through QueryEngine::closest, which takes the accelerator's
            // single-ray path (prepare_ray), not a batch of one.
            std::vector<Hit> one(rays.size());
            for (std::size_t i = 0; i < rays.size(); ++i) {
                const std::optional<Hit> h = e->closest(rays[i], p, /*want_normal=*/true);
                one[i] = h ? *h : Hit{};
            }
            expect_same(std::string("batch, ") + (s.objects.size() == 2 ? "meshes" : "mixed"), one,
                        batch, p);
            if (p != Precision::exact)
                continue;
            int hits = 0;
            for (std::size_t i = 0; i < rays.size(); ++i) {
                const Hit& x = one[i];
                const Hit& y = batch[i];
                hits += x.valid();
                EXPECT_TRUE(x.valid() == y.valid() && x.object == y.object &&
                            x.primitive == y.primitive && engine::testing::same_bits(x.t, y.t) &&
                            engine::testing::same_bits(x.t_err, y.t_err) &&
                            engine::testing::same_bits(x.u, y.u) &&
                            engine::testing::same_bits(x.v, y.v) && x.normal == y.normal &&
                            x.front_face == y.front_face)
                    << "ray " << i;
            }
            EXPECT_GT(hits, 200);
        }
    }
}

TEST(Metamorphic, TranslateSceneAndRays) {
    const Scene s = dyadic_scene(21);
    const auto rays = dyadic_rays(22, s, 600);
    const auto base = build(s);
    for (const Vec3d offset : {Vec3d{1024, -2048, 512}, Vec3d{3 << 20, 5 << 20, -(7 << 20)},
                               Vec3d{std::ldexp(1, 30), -std::ldexp(1, 30), std::ldexp(3, 29)}}) {
        auto shift = [&](const Vec3d& p) { return p + offset; };
        const auto moved = build(map_scene(s, shift, 1.0));
        std::vector<Ray> moved_rays = rays;
        for (Ray& r : moved_rays)
            r.origin = shift(r.origin);
        for (Precision p : kAll) {
            char what[64];
            std::snprintf(what, sizeof what, "translate by %.3g", offset.x);
            expect_same(what, closest(*base, rays, p), closest(*moved, moved_rays, p), p);
        }
    }
}

TEST(Metamorphic, ScaleSceneAndRays) {
    const Scene s = dyadic_scene(23);
    const auto rays = dyadic_rays(24, s, 600);
    const auto base = build(s);
    for (int k : {-20, -7, 3, 15}) {
        const double f = std::ldexp(1.0, k);
        const auto scaled = build(map_scene(
            s, [&](const Vec3d& p) { return p * f; }, f));
        std::vector<Ray> scaled_rays = rays;
        for (Ray& r : scaled_rays) {
            r.origin = r.origin * f;
            r.direction = r.direction * f;
        }
        for (Precision p : kAll) {
            expect_same("scale by 2^" + std::to_string(k), closest(*base, rays, p),
                        closest(*scaled, scaled_rays, p), p);
        }
    }
}

TEST(Metamorphic, RotateSceneAndRays) {
    const Scene s = dyadic_scene(25);
    const auto rays = dyadic_rays(26, s, 600);
    const auto base = build(s);
    // The rotations of the cube: a permutation of the axes with signs, determinant +1.
    const int perms[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {1, 0, 2}, {0, 2, 1}, {2, 1, 0}};
    int tested = 0;
    for (int pi = 0; pi < 6; ++pi) {
        const bool odd = pi >= 3;
        for (int signs = 0; signs < 8; ++signs) {
            const int flips = __builtin_popcount(static_cast<unsigned>(signs));
            if ((flips % 2 == 1) != odd)
                continue;  // keep det = +1: a mirror would flip winding
            auto rot = [&](const Vec3d& v) {
                Vec3d out;
                for (std::size_t k = 0; k < 3; ++k) {
                    const double c = v[static_cast<std::size_t>(perms[pi][k])];
                    out[k] = (signs >> k) & 1 ? -c : c;
                }
                return out;
            };
            const auto rotated = build(map_scene(s, rot, 1.0));
            std::vector<Ray> rr = rays;
            for (Ray& r : rr) {
                r.origin = rot(r.origin);
                r.direction = rot(r.direction);
            }
            for (Precision p : kAll) {
                expect_same("rotation " + std::to_string(tested), closest(*base, rays, p),
                            closest(*rotated, rr, p), p);
            }
            ++tested;
        }
    }
    EXPECT_EQ(tested, 24);
}

TEST(Metamorphic, DirectionScaleDividesT) {
    const Scene s = dyadic_scene(27);
    const auto rays = dyadic_rays(28, s, 600);
    const auto e = build(s);
    for (int k : {-20, -1, 1, 20}) {
        const double f = std::ldexp(1.0, k);
        std::vector<Ray> scaled = rays;
        for (Ray& r : scaled)
            r.direction = r.direction * f;
        for (Precision p : kAll) {
            expect_same("direction × 2^" + std::to_string(k), closest(*e, rays, p),
                        closest(*e, scaled, p), p, f);
        }
    }
    // Lengths that are not powers of two change the rounded direction itself, so the exact
    // answer moves by about an ulp: t·k must still agree to a few ulps.
    for (double f : {1e-6, 3e-3, 7.0, 1e6}) {
        std::vector<Ray> scaled = rays;
        for (Ray& r : scaled)
            r.direction = r.direction * f;
        for (Precision p : kAll) {
            char what[64];
            std::snprintf(what, sizeof what, "direction × %g", f);
            expect_same(what, closest(*e, rays, p), closest(*e, scaled, p), p, f, 16.0);
        }
    }
}

// From a point beyond the first hit (half-way to the next one), the reversed ray's first hit is
// the same surface at the same point.
TEST(Metamorphic, ReverseFromBeyondTheFirstHit) {
    const Scene s = dyadic_scene(29);
    const auto rays = dyadic_rays(30, s, 600);
    const auto e = build(s);
    for (Precision p : kAll) {
        engine::QueryOptions all_opt;
        all_opt.mode = engine::Mode::all;
        all_opt.precision = p;
        const auto all = e->intersect(rays, all_opt);
        std::vector<Ray> back;
        std::vector<Hit> first;
        std::vector<Vec3d> point;
        for (std::size_t i = 0; i < rays.size(); ++i) {
            const std::uint32_t b = all.offsets[i], n = all.offsets[i + 1] - b;
            if (n == 0)
                continue;
            const Hit& h = all.hits[b];
            const double next =
                n > 1 ? all.hits[b + 1].t : h.t + 1.0 / engine::length(rays[i].direction);
            const double beyond = h.t + 0.5 * (next - h.t);
            if (!(beyond - h.t > 1e-9 * h.t))
                continue;  // hits too close to separate
            back.push_back(Ray{rays[i].at(beyond), -rays[i].direction});
            first.push_back(h);
            point.push_back(rays[i].at(h.t));
        }
        const auto rev = closest(*e, back, p);
        std::size_t wrong = 0;
        double worst = 0;  // distance between the two hit points, relative to their size
        for (std::size_t i = 0; i < back.size(); ++i) {
            if (!rev[i].valid() || rev[i].object != first[i].object) {
                ++wrong;
                continue;
            }
            const double gap = engine::length(back[i].at(rev[i].t) - point[i]);
            worst = std::max(worst, gap / (engine::length(point[i]) + 1.0));
        }
        std::printf(
            "[ metamorph] reverse from beyond the first hit %-8s %zu rays, wrong "
            "surface %zu, points apart ≤ %.3g (relative)\n",
            engine::to_string(p), back.size(), wrong, worst);
        ::testing::Test::RecordProperty(std::string("reverse.") + engine::to_string(p) + ".wrong",
                                        std::to_string(wrong));
        if (p != Precision::fast) {
            EXPECT_GT(back.size(), 200u);
            EXPECT_EQ(wrong, 0u) << engine::to_string(p);
            EXPECT_LE(worst, 1e-12) << engine::to_string(p);
        }
    }
}

/// Lines through closed meshes: through random interior points, vertices and edge points, from
/// outside the bounding sphere. Every count must be even. `vertex_lines_asserted = false`
/// records the lines through vertices without asserting them: on a non-convex mesh a vertex
/// whose fan folds over as seen along the line is counted wrongly by the engine's merge of
/// shared-edge duplicates (see DISABLED_EvenCountThroughAFoldedVertex below).
void expect_even_counts(const Object& mesh_object, std::uint64_t seed, int n,
                        const std::string& name, bool vertex_lines_asserted = true) {
    Scene s = empty_scene();
    s.objects.push_back(mesh_object);
    const auto e = build(s);
    const engine::TriangleMesh& m = *mesh_object.mesh;
    const engine::Bounds3 b = m.bounds();
    const Vec3d c = b.center();
    const double radius = engine::length(b.diagonal());
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<Ray> rays;
    for (int i = 0; i < n; ++i) {
        const auto& t = m.triangles[rng() % m.size()];
        Vec3d target;
        switch (i % 3) {
            case 0:
                target = m.positions[t[0]];
                break;
            case 1:
                target = (m.positions[t[0]] + m.positions[t[1]]) * 0.5;
                break;
            default:
                target = c + Vec3d{u(rng), u(rng), u(rng)} * (0.2 * radius);
                break;
        }
        Vec3d dir{u(rng), u(rng), u(rng)};
        if (engine::length(dir) < 0.1)
            dir = {0.3, -0.7, 0.2};
        dir = engine::normalize(dir);
        rays.push_back(Ray{target - dir * (2 * radius), dir});
    }
    for (Precision p : kAll) {
        engine::QueryOptions opt;
        opt.mode = engine::Mode::count;
        opt.precision = p;
        const auto res = e->intersect(rays, opt);
        std::size_t odd = 0, odd_at_vertex = 0;
        StressCase bad{name, std::make_shared<Scene>(s), {}, {true}};
        for (std::size_t i = 0; i < rays.size(); ++i) {
            if (res.counts[i] % 2 == 0)
                continue;
            bad.rays.push_back(rays[i]);
            ++(i % 3 == 0 ? odd_at_vertex : odd);
        }
        if (const char* dump = std::getenv("RAYCASTD_STRESS_DUMP"); dump && !bad.rays.empty()) {
            std::string file = std::string(dump) + "/odd-" + engine::to_string(p) + "-" +
                               std::to_string(seed) + ".txt";
            std::ofstream(file) << write_case(bad, "odd crossing counts: " + name);
        }
        std::printf(
            "[ metamorph] even counts %-22s %-8s %s %d lines, odd %zu (+ %zu of the "
            "lines through vertices)\n",
            name.c_str(), engine::to_string(p), e->brute_force() ? "brute" : "embree", n, odd,
            odd_at_vertex);
        const std::string key = "even." + name + "." + engine::to_string(p);
        ::testing::Test::RecordProperty(key + ".odd", std::to_string(odd));
        ::testing::Test::RecordProperty(key + ".odd_at_vertex", std::to_string(odd_at_vertex));
        if (p != Precision::fast) {
            EXPECT_EQ(odd, 0u) << name << " " << engine::to_string(p);
            if (vertex_lines_asserted) {
                EXPECT_EQ(odd_at_vertex, 0u) << name << " " << engine::to_string(p);
            }
        }
        if (e->brute_force())
            break;  // every precision is the exact path
    }
}

TEST(Metamorphic, EvenCountsThroughClosedMeshes) {
    expect_even_counts(engine::testing::cube_object(-1, 1), 31, 1500, "cube");
    for (int level = 0; level <= 6; ++level) {
        expect_even_counts(engine::testing::icosphere_object(level, {0.1, -0.2, 0.3}, 1.0),
                           40 + static_cast<std::uint64_t>(level), level >= 5 ? 600 : 1500,
                           "icosphere " + std::to_string(level));
    }
    // Far from the origin: the float paths see the same mesh relative to its own centre.
    expect_even_counts(engine::testing::icosphere_object(3, {1e7, -1e7, 1e7}, 1.0), 50, 1500,
                       "icosphere 3 at 1e7");
}

TEST(Metamorphic, EvenCountsThroughClosedModels) {
    GenOptions g;
    g.rays = 50;
    const auto cases = closed_models(g, RAYCASTD_SHARED_DIR);
    if (cases.empty())
        GTEST_SKIP() << "models not found at " RAYCASTD_SHARED_DIR "/data/models";
    std::uint64_t seed = 60;
    for (const StressCase& c : cases) {
        expect_even_counts(c.scene->objects[0], seed++, 600, c.scene->objects[0].name,
                           /*vertex_lines_asserted=*/false);
    }
}

// Reproducer for the engine's counting at a folded vertex (spot.obj, vertex shared by triangles
// 1012, 1013, 1018, 1019, 3942 and 3947). The line passes through the vertex (to ~1e-17
// relative), where five of its triangles face the ray and one (3947, a fold of the fan as seen
// along the line) faces away; it leaves through triangle 4056. The engine reports the vertex
// twice (one front-facing and one back-facing survivor of sort_and_merge_edge_duplicates in
// engine/accel/linear_accel.cpp) and the exit once: count 3, odd, in refined and exact. Any
// generic perturbation of the line crosses an odd number of sheets at the vertex (1 here), so
// the count must be 2. Disabled until the merge is parity-safe (a consistent tie-break of
// exactly-zero edge functions, as for rasterisers' top-left rule, would make it so).
TEST(Metamorphic, DISABLED_EvenCountThroughAFoldedVertex) {
    GenOptions g;
    g.rays = 1;
    const auto cases = closed_models(g, RAYCASTD_SHARED_DIR);
    if (cases.empty() || cases[0].scene->objects[0].name != "spot/spot.obj") {
        GTEST_SKIP() << "spot.obj not found at " RAYCASTD_SHARED_DIR "/data/models";
    }
    Scene s = empty_scene();
    s.objects.push_back(cases[0].scene->objects[0]);
    const auto e = build(s);
    const Ray ray{{0x1.2af526f13adefp-1, 0x1.f65fe7700f08fp+0, -0x1.51731e8d33f2ap+2},
                  {-0x1.9041822f1757cp-4, -0x1.c2fb423de7a9bp-3, 0x1.f0eb77a252af9p-1}};
    for (Precision p : {Precision::refined, Precision::exact}) {
        engine::QueryOptions opt;
        opt.mode = engine::Mode::count;
        opt.precision = p;
        EXPECT_EQ(e->intersect({ray}, opt).counts[0], 2u) << engine::to_string(p);
    }
}

}  // namespace
}  // namespace raycastd::stress
