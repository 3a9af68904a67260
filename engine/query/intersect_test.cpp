#include "engine/query/intersect.h"

#include <cmath>
#include <limits>
#include <random>
#include <set>

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>

#include "engine/accel/linear_accel.h"
#include "engine/math/float_bounds.h"
#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

std::shared_ptr<const QueryEngine> build(Scene s) {
    auto e = QueryEngine::build(std::make_shared<Scene>(std::move(s)));
    EXPECT_TRUE(e.ok());
    return *e;
}

TEST(Query, ModesOnTutorialScene) {
    auto engine = build(testing::tutorial_spheres());
    std::vector<Ray> rays = {Ray{{0, 0, 0}, {0, 0, 1}}, Ray{{0, 0, 0}, {0, 0, -1}}};
    QueryOptions opt;
    QueryResult r = engine->intersect(rays, opt);
    ASSERT_EQ(r.hits.size(), 2u);
    EXPECT_EQ(r.hits[0].object, 2u);
    EXPECT_EQ(r.hits[0].t, 7.267949192431123);
    EXPECT_FALSE(r.hits[1].valid());
    EXPECT_EQ(r.precision, Precision::exact);

    opt.mode = Mode::any;
    r = engine->intersect(rays, opt);
    EXPECT_TRUE(r.hits[0].valid());
    EXPECT_FALSE(r.hits[1].valid());

    opt.mode = Mode::count;
    r = engine->intersect(rays, opt);
    EXPECT_EQ(r.counts, (std::vector<std::uint32_t>{4, 0}));

    opt.mode = Mode::all;
    r = engine->intersect(rays, opt);
    EXPECT_EQ(r.offsets, (std::vector<std::uint32_t>{0, 4, 4}));
    EXPECT_EQ(r.hits[1].t, 8.0);
}

// A normal not asked for is not answered: zeros on every path, spheres included (whose
// candidates come with one for front_face). The binary form's ?fields without `normal` had
// returned spheres' normals at exact (api_intersect_test's BinaryFieldsAreTheJsonNames).
TEST(Query, NormalsAreZeroUnlessAskedFor) {
    for (int big = 0; big < 2; ++big) {
        Scene s;
        s.materials.push_back(Material{});
        s.objects.push_back(testing::sphere("ball", {0, 0, 4}, 1.0, 0));
        // 320 triangles put the scene on Embree's BVHs; a cube keeps it brute force.
        s.objects.push_back(big ? testing::icosphere_object(2, {2.5, 0, 4}, 1.0)
                                : testing::cube_object(2.0, 3.0));
        auto engine = build(std::move(s));
        std::vector<Ray> rays;
        for (int k = 0; k < 64; ++k) {
            rays.push_back(Ray{{-0.5 + 0.05 * k, 0.1, -3}, {0, 0.01, 1}});  // ball, icosphere
            rays.push_back(Ray{{2.1 + 0.01 * k, 2.5, -3}, {0, 0.001, 1}});  // the cube
        }
        for (Precision p : {Precision::fast, Precision::refined, Precision::exact}) {
            for (Mode mode : {Mode::closest, Mode::all}) {
                QueryOptions opt;
                opt.precision = p;
                opt.mode = mode;
                opt.want_normal = false;
                const QueryResult r = engine->intersect(rays, opt);
                std::set<std::uint32_t> objects;
                for (const Hit& h : r.hits) {
                    if (!h.valid())
                        continue;
                    objects.insert(h.object);
                    EXPECT_EQ(h.normal, Vec3d{}) << big << " " << to_string(p) << " "
                                                 << to_string(mode) << " object " << h.object;
                }
                EXPECT_EQ(objects.size(), 2u) << big << " " << to_string(p);
            }
        }
    }
}

// A batch big enough to run in parallel gives the same answers as one ray at a time.
TEST(Query, ParallelBatchMatchesSerial) {
    auto engine = build(testing::tutorial_spheres());
    std::vector<Ray> rays;
    for (int i = 0; i < 5000; ++i) {
        rays.push_back(
            Ray{{0, 0, 0}, {0.0005 * (i % 100) - 0.025, 0.0005 * (i / 100) - 0.0125, 1}});
    }
    QueryOptions opt;
    QueryResult batch = engine->intersect(rays, opt);
    for (std::size_t i = 0; i < rays.size(); i += 37) {
        QueryResult one = engine->intersect({rays[i]}, opt);
        EXPECT_EQ(one.hits[0].t, batch.hits[i].t);
        EXPECT_EQ(one.hits[0].object, batch.hits[i].object);
    }
}

TEST(Query, ValidateRay) {
    EXPECT_TRUE(validate_ray(Ray{{0, 0, 0}, {0, 0, 1}}, 0).ok());
    Status zero = validate_ray(Ray{{0, 0, 0}, {0, 0, 0}}, 3);
    EXPECT_EQ(zero.code, Code::invalid_ray);
    EXPECT_EQ(zero.path, "/rays/3/direction");
    EXPECT_NE(zero.message.find("ray 3"), std::string::npos);
    Status nan = validate_ray(Ray{{0, 0, std::nan("")}, {0, 0, 1}}, 0);
    EXPECT_EQ(nan.path, "/rays/0/origin");
    Status order = validate_ray(Ray{{0, 0, 0}, {0, 0, 1}, 2, 1}, 1);
    EXPECT_EQ(order.code, Code::invalid_ray);
    Status overflow = validate_ray(Ray{{0, 0, 0}, {1e200, 1e200, 0}}, 0);
    EXPECT_EQ(overflow.code, Code::invalid_ray);
}

TEST(Query, BuildRejectsInvalidScene) {
    Scene s = testing::tutorial_spheres();
    s.objects[1].sphere.radius = -1;
    auto e = QueryEngine::build(std::make_shared<Scene>(s));
    ASSERT_FALSE(e.ok());
    EXPECT_EQ(e.status().code, Code::invalid_scene);
    EXPECT_EQ(e.status().path, "/objects/1/radius");
}

// A scene whose extent passes the largest double is refused: a sphere reaching past it, a
// triangle whose edges overflow, and two objects each within range whose distance is not (a
// helper's review: every point query of the first answered "on the surface", the second was
// never hit). Up to ±8e307 on each axis a scene is taken.
TEST(Query, BuildRejectsASceneWiderThanDouble) {
    const auto refused = [](Scene s) {
        auto e = QueryEngine::build(std::make_shared<Scene>(std::move(s)));
        return e.ok() ? std::string("built") : e.status().path;
    };
    const auto scene_of = [](std::vector<Object> objects) {
        Scene s;
        s.materials.push_back(Material{});
        s.objects = std::move(objects);
        return s;
    };
    const Object tiny = testing::sphere("tiny", {0, 0, 0}, 1.0, 0);
    EXPECT_EQ(refused(scene_of({tiny, testing::sphere("past", {1e308, 0, 0}, 1e308, 0)})),
              "/objects/1");
    EXPECT_EQ(refused(scene_of({testing::mesh_object(
                  "wide", {{-1e308, -1e308, 5}, {1e308, -1e308, 5}, {0, 1e308, 5}}, {{0, 1, 2}})})),
              "/objects/0");
    EXPECT_EQ(refused(scene_of({testing::sphere("left", {-1e308, 0, 0}, 1.0, 0), tiny,
                                testing::sphere("right", {1e308, 0, 0}, 1.0, 0)})),
              "/objects/2");
    EXPECT_EQ(refused(scene_of({testing::sphere("left", {-8e307, 0, 0}, 1e306, 0),
                                testing::sphere("right", {8e307, 0, 0}, 1e306, 0)})),
              "built");
    Status st = validate(scene_of({tiny, testing::sphere("past", {1e308, 0, 0}, 1e308, 0)}));
    EXPECT_EQ(st.code, Code::invalid_scene);
    EXPECT_NE(st.message.find("object 1's extent"), std::string::npos) << st.message;
}

// A batch whose token has fired answers Code::cancelled in every mode, on a BVH and by brute
// force, and intersect_blocks fetches and hands out no block; a token that can fire but does not
// changes no answer.
TEST(Query, CancelledBatchAnswersCancelledAndAnArmedTokenChangesNothing) {
    Scene big = testing::tutorial_spheres();
    big.objects.push_back(testing::icosphere_object(2, {0, 0, 20}, 3.0));
    const auto bvh = build(std::move(big));
    const auto brute = build(testing::tutorial_spheres());
    ASSERT_FALSE(bvh->brute_force());
    ASSERT_TRUE(brute->brute_force());
    std::vector<Ray> rays;
    for (int i = 0; i < 5 * 1024 + 7; ++i) {
        rays.push_back(Ray{{0, 0, 0}, {0.002 * (i % 64) - 0.064, 0.002 * (i / 64) - 0.05, 1}});
    }
    const CancelToken stopped = CancelToken::make();
    stopped.cancel();
    const CancelToken armed =
        CancelToken::make(CancelToken::Clock::now() + std::chrono::hours(1), [] { return false; });
    for (const auto* engine : {bvh.get(), brute.get()}) {
        for (Mode mode : {Mode::closest, Mode::any, Mode::all, Mode::count}) {
            QueryOptions opt;
            opt.mode = mode;
            const QueryResult plain = engine->intersect(rays, opt);
            QueryResult out;
            opt.cancel = stopped;
            EXPECT_EQ(engine->intersect(rays, opt, out).code, Code::cancelled) << to_string(mode);
            opt.cancel = armed;
            ASSERT_TRUE(engine->intersect(rays, opt, out).ok());
            ASSERT_EQ(out.hits.size(), plain.hits.size());
            for (std::size_t i = 0; i < out.hits.size(); ++i) {
                ASSERT_EQ(out.hits[i].t, plain.hits[i].t) << i;
                ASSERT_EQ(out.hits[i].object, plain.hits[i].object) << i;
            }
            EXPECT_EQ(out.counts, plain.counts);
            EXPECT_EQ(out.offsets, plain.offsets);
        }
        QueryOptions opt;
        opt.cancel = stopped;
        int fetched = 0, sunk = 0;
        const Status st = engine->intersect_blocks(
            rays.size(), opt,
            [&](std::size_t, std::size_t, Ray*) {
                ++fetched;
                return true;
            },
            [&](std::size_t, std::size_t, const Hit*) { ++sunk; });
        EXPECT_EQ(st.code, Code::cancelled);
        EXPECT_EQ(fetched, 0);
        EXPECT_EQ(sunk, 0);
    }
    EXPECT_FALSE(armed.fired());
}

// The brute-force pass of the worked solution over one mesh asks its token every 65,536
// triangles, from the first on: a token past its deadline gives no answer, and says so.
TEST(Query, BruteForceOverAMeshStopsWhenItsTokenHasFired) {
    Scene s;
    s.objects.push_back(testing::icosphere_object(3, {0, 0, 10}, 2.0));
    const Ray ray{{0, 0, 0}, {0, 0, 1}};
    ASSERT_TRUE(closest_in_object_by_brute_force(s, 0, ray, false));
    const CancelToken late = CancelToken::make(CancelToken::Clock::now() - std::chrono::seconds(1));
    EXPECT_FALSE(closest_in_object_by_brute_force(s, 0, ray, false, late));
    EXPECT_TRUE(late.fired());
    EXPECT_FALSE(closest_by_brute_force(s, ray, true, late));
}

// intersect_blocks hands out the blocks intersect() traces and answers them as intersect() does,
// whatever the caller's format; a block whose source reports a bad ray is neither traced nor
// handed to the sink.
TEST(Query, IntersectBlocksAnswersAsIntersect) {
    Scene s = testing::tutorial_spheres();
    s.objects.push_back(testing::icosphere_object(2, {0, 0, 20}, 3.0));  // past the brute force
    auto engine = build(std::move(s));
    ASSERT_FALSE(engine->brute_force());
    std::vector<Ray> rays;
    for (int i = 0; i < 3 * 1024 + 100; ++i) {
        rays.push_back(Ray{{0, 0, 0}, {0.002 * (i % 64) - 0.064, 0.002 * (i / 64) - 0.05, 1}});
    }
    for (Mode mode : {Mode::closest, Mode::any}) {
        for (Precision p : {Precision::fast, Precision::refined, Precision::exact}) {
            const QueryOptions opt{mode, p, true};
            const QueryResult whole = engine->intersect(rays, opt);
            std::vector<Hit> got(rays.size());
            std::vector<int> stored(rays.size(), 0);
            engine->intersect_blocks(
                rays.size(), opt,
                [&](std::size_t b, std::size_t e, Ray* out) {
                    std::copy(rays.begin() + b, rays.begin() + e, out);
                    return b != 2048;  // the third block "has a bad ray"
                },
                [&](std::size_t b, std::size_t e, const Hit* h) {
                    for (std::size_t i = b; i < e; ++i) {
                        got[i] = h[i - b];
                        ++stored[i];
                    }
                });
            int hits = 0;
            for (std::size_t i = 0; i < rays.size(); ++i) {
                const bool skipped = i >= 2048 && i < 3072;
                ASSERT_EQ(stored[i], skipped ? 0 : 1) << i;
                if (skipped)
                    continue;
                ASSERT_EQ(got[i].valid(), whole.hits[i].valid()) << i;
                EXPECT_EQ(got[i].t, whole.hits[i].t) << i;
                EXPECT_EQ(got[i].object, whole.hits[i].object) << i;
                EXPECT_EQ(got[i].primitive, whole.hits[i].primitive) << i;
                EXPECT_EQ(got[i].normal, whole.hits[i].normal) << i;
                hits += got[i].valid();
            }
            EXPECT_GT(hits, 1000) << to_string(mode) << " " << to_string(p);
        }
    }
}

// A brute-force scene traces each block with a parallel loop of its own; with many threads, a
// thread waiting in one block's loop must not take up another block and reuse its buffers.
// Before the blocks were isolated this gave thousands of wrong answers with 8-16 threads (and
// none with 2, this machine's count: hence the arena of 16).
TEST(Query, BatchesOnManyThreadsKeepTheirBlocksApart) {
    auto engine = build(testing::tutorial_spheres());
    ASSERT_TRUE(engine->brute_force());
    std::vector<Ray> rays;
    for (int i = 0; i < 100 * 1024 + 17; ++i) {
        // Every ray different, so that a hit handed to the wrong ray shows.
        rays.push_back(Ray{{0, 0, 0}, {1e-4 * (i % 317) - 0.016, 1e-4 * (i / 317) - 0.016, 1}});
    }
    const QueryOptions opt{Mode::closest, Precision::exact, true};
    const QueryResult want = engine->intersect(rays, opt);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 16);
    tbb::task_arena arena(16);
    std::size_t wrong = 0;
    arena.execute([&] {
        for (int run = 0; run < 8; ++run) {
            std::vector<Hit> got(rays.size());
            engine->intersect_blocks(
                rays.size(), opt,
                [&](std::size_t b, std::size_t e, Ray* out) {
                    std::copy(rays.begin() + b, rays.begin() + e, out);
                    return true;
                },
                [&](std::size_t b, std::size_t e, const Hit* h) {
                    std::copy(h, h + (e - b), got.begin() + b);
                });
            for (std::size_t i = 0; i < rays.size(); ++i)
                wrong += got[i].t != want.hits[i].t || got[i].object != want.hits[i].object;
        }
    });
    EXPECT_EQ(wrong, 0u);
}

// Scenes of every size from 1e-40 to 1e40 across, on Embree's BVHs: fast and refined agree
// with exact on random rays, some with directions of the scene's own length. Unscaled (before
// embree::Impl::unit, 2026-12-05) Embree's float tests had answered only between ~1e-12 and
// ~1e12: smaller meshes were missed at fast and refined, larger ones answered t = inf at
// fast, one 1e18 across aborted the process (an assertion in Embree), and past 1e20 every
// precision missed.
TEST(EmbreeAccel, ScenesOfEverySizeAreAnswered) {
    // Every fourth power of ten to ±40, then to ±280 by twenties: past ~1e±105 refined's widened
    // triangles had been formed in scene units, whose cross products under- or overflowed (no
    // widening: missed hits near edges), and past ~1e±154 the diagonal itself (a helper's
    // review).
    std::vector<int> exponents;
    for (int e = -40; e <= 40; e += 4)
        exponents.push_back(e);
    for (int e = 60; e <= 280; e += 20) {
        exponents.push_back(e);
        exponents.push_back(-e);
    }
    for (int e : exponents) {
        const double s = std::pow(10.0, e);
        Scene scene;
        scene.materials.push_back(Material{});
        scene.objects.push_back(testing::icosphere_object(3, {0, 0, 0}, s));
        scene.objects.push_back(testing::icosphere_object(1, {3 * s, 0, 0}, s));
        scene.objects.push_back(testing::sphere("ball", {0, 3 * s, 0}, s, 0));
        auto engine = QueryEngine::build(std::make_shared<Scene>(std::move(scene)));
        ASSERT_TRUE(engine.ok());
        EXPECT_FALSE((*engine)->brute_force()) << s;
        std::mt19937_64 rng(static_cast<std::uint64_t>(e + 100));
        std::uniform_real_distribution<double> u(-1, 1);
        std::vector<Ray> rays;
        for (int i = 0; i < 300; ++i) {
            const Vec3d o{u(rng) * 6 * s, u(rng) * 6 * s, u(rng) * 6 * s};
            // Aimed at one of the three objects' neighbourhoods, so that most rays hit.
            const Vec3d target = Vec3d{i % 3 == 1 ? 3 * s : 0, i % 3 == 2 ? 3 * s : 0, 0} +
                                 Vec3d{u(rng), u(rng), u(rng)} * (0.8 * s);
            const Vec3d d = target - o;
            rays.push_back(Ray{o, i % 2 ? d : d * (1.0 / s)});
        }
        const QueryResult exact =
            (*engine)->intersect(rays, QueryOptions{Mode::closest, Precision::exact, true});
        int hits = 0;
        for (Precision p : {Precision::fast, Precision::refined}) {
            const QueryResult r = (*engine)->intersect(rays, QueryOptions{Mode::closest, p, true});
            EXPECT_EQ(r.precision, p);
            for (std::size_t i = 0; i < rays.size(); ++i) {
                const Hit& a = r.hits[i];
                const Hit& b = exact.hits[i];
                ASSERT_EQ(a.valid(), b.valid()) << s << " " << to_string(p) << " ray " << i;
                if (!b.valid())
                    continue;
                hits += p == Precision::refined;
                EXPECT_EQ(a.object, b.object) << s << " " << to_string(p) << " ray " << i;
                EXPECT_NEAR(a.t, b.t, a.t_err + b.t_err) << s << " " << to_string(p) << " " << i;
                EXPECT_NEAR(length(a.normal), 1.0, 1e-6) << s << " " << to_string(p) << " " << i;
            }
        }
        EXPECT_GT(hits, 150) << s;
    }
}

// Directions far longer or shorter than the scene (1e150 against a mesh 1e-200 across, 1e-160
// against one 1e-50 across seen from 1e100 away): prepare_ray's float length overflowed, its
// tfar was NaN and Embree aborted the process on its assertion (a second review). Every
// precision, mode and batch size now answers, as the linear scan does.
TEST(EmbreeAccel, ExtremeDirectionsAreAnsweredWithoutAborting) {
    struct Case {
        double size, distance, direction;
    };
    for (const Case& c : {Case{1e-200, 3, 1e150}, Case{1e-170, 1e6, 1e154},
                          Case{1e-50, 1e150, 1e-160}, Case{1, 3, 1e300}}) {
        Scene scene;
        scene.materials.push_back(Material{});
        scene.objects.push_back(testing::icosphere_object(2, {0, 0, 0}, c.size));
        scene.objects.push_back(testing::sphere("a", {1.5 * c.size, 0, 0}, 0.4 * c.size, 0));
        const auto shared = std::make_shared<Scene>(std::move(scene));
        auto engine = QueryEngine::build(shared);
        ASSERT_TRUE(engine.ok());
        std::vector<Ray> rays;
        for (int k = 0; k < 16; ++k) {
            rays.push_back(
                Ray{{0.01 * k * c.size, 0.02 * c.size, c.distance * c.size}, {0, 0, -c.direction}});
        }
        const std::optional<Hit> want = linear_closest(*shared, rays[0], false);
        ASSERT_TRUE(want) << c.size;
        for (Precision p : {Precision::fast, Precision::refined, Precision::exact}) {
            for (Mode mode : {Mode::closest, Mode::any, Mode::count}) {
                const QueryResult r = (*engine)->intersect(rays, QueryOptions{mode, p, false});
                if (mode == Mode::closest) {
                    ASSERT_TRUE(r.hits[0].valid()) << c.size << " " << to_string(p);
                    EXPECT_NEAR(r.hits[0].t, want->t, r.hits[0].t_err + want->t_err)
                        << c.size << " " << to_string(p);
                } else if (mode == Mode::any) {
                    EXPECT_TRUE(r.hits[0].valid()) << c.size << " " << to_string(p);
                } else {
                    EXPECT_EQ(r.counts[0], 2u) << c.size << " " << to_string(p);
                }
            }
        }
    }
}

// A scene finite in double but wider than float can hold (±1e39): Embree sees it scaled to unit
// size (embree::Impl::unit), and refined and exact answer it as in double. Its triangles are 1e-9
// of its size and 1e-38 apart in depth, below float's resolution there: fast, which takes
// Embree's float answer, may miss them, but answers without NaNs or infinities. (Until
// 2026-12-05 such a scene was brute force: Embree saw its coordinates unscaled.) Past 1e290
// across a scene is still brute force, at every precision.
// A crossing whose t overflows double (a direction 1e-10 long towards a sphere 1e300 away:
// t ≈ 9e309) is no hit, in every mode and at every precision, on the brute-force scan and on
// Embree's BVHs, for near rays, far rays moved to the scene and rays too far to be moved. It had
// been answered as a hit at t = inf (JSON's null, the binary form's miss) whose point and normal
// were NaN, since the default tmax = +inf admitted it; then, a helper's review found, `any` still
// said true on a far ray's moved one. Each overflowing ray has a twin 1,000 times
// longer whose t fits, and hits.
TEST(EmbreeAccel, CrossingsPastTheLargestDoubleAreNoHits) {
    struct Case {
        std::string what;
        Scene scene;
        Ray overflows, fits;
        std::uint32_t crossings;  // of `fits`
        bool brute_force;
    };
    // A sphere at z = at and, 3 sizes beyond, an icosphere of 320 triangles (with the sphere,
    // over QueryEngine's 16 primitives: Embree's BVHs) or a single triangle (brute force), all
    // of radius `size`.
    const auto scene = [](bool big, double size, double at) {
        Scene s;
        s.materials.push_back(Material{});
        s.objects.push_back(testing::sphere("ball", {0, 0, at}, size, 0));
        const double z = at + 3 * size;
        if (big) {
            s.objects.push_back(testing::icosphere_object(2, {0, 0, z}, size));
        } else {
            s.objects.push_back(testing::mesh_object(
                "triangle", {{-size, -size, z}, {size, -size, z}, {0, size, z}}, {{0, 1, 2}}));
        }
        return s;
    };
    std::vector<Case> cases;
    for (int big = 0; big < 2; ++big) {
        const std::string how = big ? ", BVH" : ", brute force";
        const std::uint32_t n = big ? 4 : 3;
        // Near rays: a scene 1e300 away from the origin (wider than Embree's float frame takes:
        // the scan, big or not), and one 1e200 across from 2e200 (Embree's BVHs when big).
        cases.push_back({"near, 1e300 away" + how, scene(big, 1e299, 1e300),
                         Ray{{0, 0, 0}, {0, 0, 1e-10}}, Ray{{0, 0, 0}, {0, 0, 1e-7}}, n, true});
        cases.push_back({"near, 1e200 across" + how, scene(big, 1e199, 0.0),
                         Ray{{0, 0, -2e200}, {0, 0, 1e-110}}, Ray{{0, 0, -2e200}, {0, 0, 1e-107}},
                         n, !big});
        // Far rays moved to the scene (1e20 scene sizes away), and too far to be moved (1e200
        // away: the kernels on the client's ray; from 2⁹⁰⁰ radii a sphere is below the
        // kernel's resolution and missed, docs/numerics.md).
        cases.push_back({"far, moved" + how, scene(big, 1e150, 0.0),
                         Ray{{0, 0, -1e170}, {0, 0, 1e-140}}, Ray{{0, 0, -1e170}, {0, 0, 1e-137}},
                         n, !big});
        cases.push_back({"far, not moved" + how, scene(big, 1.0, 0.0),
                         Ray{{0, 0, -1e200}, {0, 0, 1e-110}}, Ray{{0, 0, -1e200}, {0, 0, 1e-105}},
                         n, !big});
    }
    for (Case& c : cases) {
        auto engine = build(std::move(c.scene));
        EXPECT_EQ(engine->brute_force(), c.brute_force) << c.what;
        const std::vector<Ray> rays = {c.overflows, c.fits};
        for (Precision p : {Precision::fast, Precision::refined, Precision::exact}) {
            const std::string at = c.what + ", " + to_string(p);
            QueryResult r = engine->intersect(rays, QueryOptions{Mode::closest, p, true});
            EXPECT_FALSE(r.hits[0].valid()) << at << ": t " << r.hits[0].t;
            ASSERT_TRUE(r.hits[1].valid()) << at;
            EXPECT_TRUE(std::isfinite(r.hits[1].t)) << at;
            EXPECT_GT(r.hits[1].t, 1e304) << at;
            EXPECT_FALSE(engine->closest(c.overflows, p, true).has_value()) << at;
            r = engine->intersect(rays, QueryOptions{Mode::all, p, true});
            EXPECT_EQ(r.offsets, (std::vector<std::uint32_t>{0, 0, c.crossings})) << at;
            for (const Hit& h : r.hits)
                EXPECT_TRUE(std::isfinite(h.t)) << at;
            r = engine->intersect(rays, QueryOptions{Mode::count, p, true});
            EXPECT_EQ(r.counts, (std::vector<std::uint32_t>{0, c.crossings})) << at;
            r = engine->intersect(rays, QueryOptions{Mode::any, p, true});
            EXPECT_FALSE(r.hits[0].valid()) << at;
            EXPECT_TRUE(r.hits[1].valid()) << at;
            EXPECT_FALSE(engine->occluded(c.overflows, p)) << at;
        }
    }
}

// A far ray whose range ends near double's limits, as clients send them for "unbounded" (JSON
// has no infinity): tmax 1e308 or the largest double, tmin -1e308, on a direction 4 long per axis,
// whose τ = t·2^exp of those ends overflows on the way to the scene; and ends of 5e-324 on a
// direction 2^-10 long, whose τ underflows. Such rays were not moved to the scene, and the far
// kernels, whose shear of an oblique ray from 2^66 away mixes in rounding far larger than the
// scene, lost its mesh's hits in every mode and at every precision (a helper's review: a
// triangle seen along (1, 1, 1) from -2^66·(1, 1, 1) with tmax 1e308). Each is answered as the
// same ray with the default range, on the brute-force scan and on Embree's BVHs.
TEST(EmbreeAccel, FarRaysWithRangeEndsNearDoublesLimitsHit) {
    constexpr double kMax = std::numeric_limits<double>::max();
    constexpr double kTiny = std::numeric_limits<double>::denorm_min();
    for (int big = 0; big < 2; ++big) {
        // Along the line x = y = z: a unit sphere at the origin, then a triangle crossed at
        // (0.1, 0.1, 0.1) or an icosphere of 320 triangles centred at (3, 3, 3).
        Scene s;
        s.materials.push_back(Material{});
        s.objects.push_back(testing::sphere("ball", {0, 0, 0}, 1.0, 0));
        if (big) {
            s.objects.push_back(testing::icosphere_object(2, {3, 3, 3}, 1.0));
        } else {
            s.objects.push_back(testing::mesh_object(
                "triangle", {{-1, -1, 0.1}, {1, -1, 0.1}, {0, 1, 0.1}}, {{0, 1, 2}}));
        }
        const std::uint32_t crossings = big ? 4 : 3;
        auto engine = build(std::move(s));
        EXPECT_EQ(engine->brute_force(), !big);
        struct Case {
            double length, tmin, tmax;
            bool hits;
        };
        for (const Case& c :
             {Case{4, 0, 1e308, true}, Case{4, 0, kMax, true}, Case{4, -1e308, kInfinity, true},
              Case{4, -kMax, kMax, true}, Case{0x1p-10, kTiny, kInfinity, true},
              Case{0x1p-10, -1e308, 1e308, true}, Case{0x1p-10, 0, kTiny, false}}) {
            const Ray plain{{-0x1p66, -0x1p66, -0x1p66}, {c.length, c.length, c.length}};
            const Ray ray{plain.origin, plain.direction, c.tmin, c.tmax};
            for (Precision p : {Precision::fast, Precision::refined, Precision::exact}) {
                const std::string at = std::string(big ? "BVH" : "brute force") + ", length " +
                                       std::to_string(c.length) + ", [" + std::to_string(c.tmin) +
                                       ", " + std::to_string(c.tmax) + "], " + to_string(p);
                const std::vector<Ray> rays = {plain, ray};
                QueryResult r = engine->intersect(rays, QueryOptions{Mode::all, p, true});
                ASSERT_EQ(r.offsets.size(), 3u) << at;
                EXPECT_EQ(r.offsets[1], crossings) << at;
                EXPECT_EQ(r.offsets[2] - r.offsets[1], c.hits ? crossings : 0u) << at;
                for (std::uint32_t k = 0; c.hits && k < crossings && r.offsets[2] == 2 * crossings;
                     ++k) {
                    EXPECT_EQ(r.hits[crossings + k].t, r.hits[k].t) << at << " hit " << k;
                    EXPECT_EQ(r.hits[crossings + k].object, r.hits[k].object) << at;
                }
                r = engine->intersect(rays, QueryOptions{Mode::closest, p, true});
                ASSERT_TRUE(r.hits[0].valid()) << at;
                EXPECT_EQ(r.hits[1].valid(), c.hits) << at;
                if (c.hits && r.hits[1].valid()) {
                    EXPECT_EQ(r.hits[1].t, r.hits[0].t) << at;
                }
                r = engine->intersect(rays, QueryOptions{Mode::count, p, true});
                EXPECT_EQ(r.counts, (std::vector<std::uint32_t>{crossings, c.hits ? crossings : 0}))
                    << at;
                r = engine->intersect(rays, QueryOptions{Mode::any, p, true});
                EXPECT_EQ(r.hits[1].valid(), c.hits) << at;
                EXPECT_EQ(engine->occluded(ray, p), c.hits) << at;
            }
        }
    }
}

// hit_point: origin + t·direction for near rays, bit for bit; on the surface for rays from far
// away, where that sum rounds by u·|origin| (2^66·u = 8,192 below: a triangle's hit at
// (0.1, 0.1, 0.1) came out as (0, 0, 0), a sphere's at z = -0.8 as z = 0).
TEST(Query, HitPointsOfFarRaysAreOnTheSurface) {
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(
        testing::mesh_object("triangle", {{-1, -1, 0.1}, {1, -1, 0.1}, {0, 1, 0.1}}, {{0, 1, 2}}));
    s.objects.push_back(testing::sphere("ball", {5, 0, 0}, 1.0, 0));
    const auto scene = std::make_shared<Scene>(std::move(s));
    auto engine = QueryEngine::build(scene);
    ASSERT_TRUE(engine.ok());
    struct Case {
        Ray ray;
        Vec3d want;
    };
    const Case cases[] = {
        {Ray{{-0x1p66, -0x1p66, -0x1p66}, {2, 2, 2}}, {0.1, 0.1, 0.1}},
        {Ray{{5.6, 0, -0x1p66}, {0, 0, 1}}, {5.6, 0, -0.8}},
    };
    for (Precision p : {Precision::fast, Precision::refined, Precision::exact}) {
        const double tol = p == Precision::fast ? 1e-6 : 4e-15;
        for (const Case& c : cases) {
            const std::optional<Hit> h = (*engine)->closest(c.ray, p, false);
            ASSERT_TRUE(h) << to_string(p);
            const Vec3d got = hit_point(*scene, c.ray, *h);
            for (int k = 0; k < 3; ++k)
                EXPECT_NEAR(got[k], c.want[k], tol) << to_string(p) << " " << k;
            EXPECT_GT(length(c.ray.at(h->t) - c.want), 0.05) << "the sum itself is accurate?";
        }
        // Both crossings of a unit sphere from 2^60 away round to one t (2^60): the exit's point
        // is on the far side, from the hit's own normal (a helper's review: both had been put
        // at (0, 0.5, -0.866)).
        const Ray through{{5, 0.5, -0x1p60}, {0, 0, 1}};
        const QueryResult all = (*engine)->intersect({through}, QueryOptions{Mode::all, p, true});
        ASSERT_EQ(all.offsets.back(), 2u) << to_string(p);
        EXPECT_EQ(all.hits[0].t, all.hits[1].t) << to_string(p);
        for (int k = 0; k < 2; ++k) {
            const Vec3d got = hit_point(*scene, through, all.hits[k]);
            const Vec3d want{5, 0.5, (k == 0 ? -1 : 1) * std::sqrt(0.75)};
            EXPECT_LT(length(got - want), tol) << to_string(p) << " crossing " << k;
        }
        // Near rays: the sum, bit for bit.
        for (const Ray& near : {Ray{{0.1, 0.1, -3}, {0, 0, 1}}, Ray{{5.6, 0, -3}, {0, 0, 1}}}) {
            const std::optional<Hit> h = (*engine)->closest(near, p, false);
            ASSERT_TRUE(h);
            EXPECT_EQ(hit_point(*scene, near, *h), near.at(h->t));
        }
    }
}

// surface_point's bound holds the point's distance from the surface (what a spawned origin must
// clear, shade/spawn.h), and near_every_object() is a safe shortcut: where it says near, every
// hit's point is the sum, and surface_point() is false. A scene with an object of size 0 is
// never near.
TEST(Query, NearEveryObjectAndSurfacePointErrors) {
    // A tilted triangle (the plane x + 2y + 4z = 1), a unit ball, and a triangle in z = 0, where
    // a point's rounding across the plane is exactly 0 and only the bound's floor (u of the
    // triangle's size) moves a spawned origin off it.
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(
        testing::mesh_object("tilted", {{1, 0, 0}, {-3, 0, 1}, {1, 2, -1}}, {{0, 1, 2}}));
    s.objects.push_back(testing::sphere("ball", {5, 0, 0}, 1.0, 0));
    s.objects.push_back(
        testing::mesh_object("flat", {{-1, -3, 0}, {1, -3, 0}, {0, -1, 0}}, {{0, 1, 2}}));
    const auto scene = std::make_shared<Scene>(s);
    auto built = QueryEngine::build(scene);
    ASSERT_TRUE(built.ok());
    const QueryEngine& engine = **built;
    // The smallest object is the ball (radius 1); the bounds reach 4.5 from their centre.
    EXPECT_TRUE(engine.near_every_object(Ray{{2, 0, -1e5}, {0, 0, 1}}));
    EXPECT_FALSE(engine.near_every_object(Ray{{2, 0, -0x1p20}, {0, 0, 1}}));
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> unit(-1, 1), exponent(8, 30);
    int near = 0, far = 0, flat = 0;
    for (int i = 0; i < 6000; ++i) {
        Vec3d aim;
        if (i % 3 == 0) {
            const double x = -0.5 + 0.4 * unit(rng), y = 0.6 + 0.3 * unit(rng);
            aim = {x, y, (1 - x - 2 * y) / 4};
        } else if (i % 3 == 1) {
            aim = {5 + 0.9 * unit(rng), 0.5 * unit(rng), 0.0};
        } else {
            aim = {0.3 * unit(rng), -2.4 + 0.2 * unit(rng), 0.0};
        }
        const Vec3d d = normalize(Vec3d{unit(rng), unit(rng), unit(rng)});
        const Ray ray{aim - d * std::exp2(exponent(rng)), d};
        const std::optional<Hit> h = engine.closest(ray, Precision::exact, true);
        if (!h)
            continue;
        Vec3d p, err;
        const bool on_surface = surface_point(*scene, ray, *h, p, err);
        if (engine.near_every_object(ray)) {
            ++near;
            EXPECT_FALSE(on_surface) << i;
            continue;
        }
        if (!on_surface)
            continue;
        ++far;
        // The point's distance from its surface, in long double (the tilted plane's products
        // by 2 and 4 are exact, its sums all but so).
        using LD = long double;
        Vec3d n;
        LD off;
        if (h->object == 0) {
            n = Vec3d{1, 2, 4} / std::sqrt(21.0);
            off = std::abs(LD(p.x) - 1 + 2 * LD(p.y) + 4 * LD(p.z)) / std::sqrt(LD(21));
        } else if (h->object == 1) {
            n = normalize(p - Vec3d{5, 0, 0});
            const LD x = LD(p.x) - 5, y = p.y, z = p.z;
            off = std::abs(std::sqrt(x * x + y * y + z * z) - 1);
        } else {
            ++flat;
            n = {0, 0, 1};
            off = std::abs(LD(p.z));
            EXPECT_GE(err.z, 2 * kDoubleUnitRoundoff) << i;  // the floor: u of the size, 2
        }
        EXPECT_LE(off, LD(dot(abs(n), err))) << i;
        // And a bound of the objects' own precision (a few u of unit-sized objects within 6 of
        // the origin), not one that holds by being large.
        EXPECT_LT(dot(abs(n), err), 1e-14) << i;
    }
    EXPECT_GT(near, 500);
    EXPECT_GT(far, 500);
    EXPECT_GT(flat, 100);
    // A far sphere hit whose normal is not a unit vector keeps the sum: c + r·n would not be on
    // the sphere (a zero normal from `fast` had put the point at the centre: a helper's review).
    {
        const Ray ray{{5, 0.5, -0x1p40}, {0, 0, 1}};
        Hit h = *engine.closest(ray, Precision::exact, true);
        ASSERT_EQ(h.object, 1u);
        Vec3d p, err;
        EXPECT_TRUE(surface_point(*scene, ray, h, p, err));
        h.normal = {2, 0, 0};
        EXPECT_FALSE(surface_point(*scene, ray, h, p, err));
        EXPECT_EQ(hit_point(*scene, ray, h), ray.at(h.t));
    }
    // Two spheres of radius 1.01 at 2^66 and 2^66 + 2^14: their bounds' centre rounds onto the
    // first (a helper's review), which near_every_object's reach must allow for.
    {
        Scene twin;
        twin.materials.push_back(Material{});
        twin.objects.push_back(testing::sphere("a", {0x1p66, 0, 0}, 1.01, 0));
        twin.objects.push_back(testing::sphere("b", {0x1p66 + 0x1p14, 0, 0}, 1.01, 0));
        auto e = QueryEngine::build(std::make_shared<Scene>(twin));
        ASSERT_TRUE(e.ok());
        for (double x = 0x1p66 - 0x1p21; x <= 0x1p66 + 0x1p21;
             x += 0x1p14) {  // ulp 2^13, then 2^14
            const Ray ray{{x, 0, 0}, {0, 1, 0}};
            const bool is_near = (*e)->near_every_object(ray);
            for (std::uint32_t k = 0; k < 2; ++k) {
                Hit h;
                h.object = k;
                h.t = 1.0;
                h.normal = {0, 1, 0};
                Vec3d p, err;
                EXPECT_FALSE(is_near && surface_point(twin, ray, h, p, err)) << x << " " << k;
            }
        }
    }
    // A triangle whose corners coincide is never hit and does not count (one had turned the
    // shortcut off for the whole scene: a review); a sliver 1e-9 across does, and 2^20 of it is
    // less than the scene's extent, so no origin is near.
    Scene with_point = s;
    with_point.objects.push_back(
        testing::mesh_object("point", {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}}, {{0, 1, 2}}));
    auto pointed = QueryEngine::build(std::make_shared<Scene>(with_point));
    ASSERT_TRUE(pointed.ok());
    EXPECT_TRUE((*pointed)->near_every_object(Ray{{2, 0, -3}, {0, 0, 1}}));
    s.objects.push_back(testing::mesh_object(
        "sliver", {{1, 1, 1}, {1 + 1e-9, 1, 1}, {1, 1 + 1e-9, 1}}, {{0, 1, 2}}));
    auto tiny = QueryEngine::build(std::make_shared<Scene>(s));
    ASSERT_TRUE(tiny.ok());
    EXPECT_FALSE((*tiny)->near_every_object(Ray{{2, 0, -3}, {0, 0, 1}}));
}

TEST(EmbreeAccel, SceneWiderThanFloatIsAnswered) {
    for (double scale : {1.0, 1e260}) {
        Scene s;
        s.materials.push_back(Material{});
        for (int i = 0; i < 20; ++i) {
            const double x = (i % 2 ? 1e39 : -1e39) * scale;
            const double z = (10.0 + i) * scale;
            const double h = 1e30 * scale;
            s.objects.push_back(testing::mesh_object(
                "t" + std::to_string(i), {{x - h, -h, z}, {x + h, -h, z}, {x, h, z}}, {{0, 1, 2}}));
        }
        auto engine = QueryEngine::build(std::make_shared<Scene>(s));
        ASSERT_TRUE(engine.ok());
        EXPECT_EQ((*engine)->brute_force(), scale > 1.0);
        const std::vector<Ray> rays = {Ray{{-1e39 * scale, 0, 0}, {0, 0, 1}},
                                       Ray{{1e39 * scale, 0, 100 * scale}, {0, 0, -1}}};
        for (Precision p : {Precision::fast, Precision::refined, Precision::exact}) {
            const QueryResult r = (*engine)->intersect(rays, QueryOptions{Mode::closest, p, true});
            if (p == Precision::fast && scale == 1.0) {
                for (const Hit& h : r.hits) {
                    if (h.valid()) {
                        EXPECT_TRUE(std::isfinite(h.t) && is_finite(h.normal));
                    }
                }
                continue;
            }
            ASSERT_TRUE(r.hits[0].valid() && r.hits[1].valid()) << to_string(p) << " " << scale;
            EXPECT_EQ(r.hits[0].object, 0u);
            EXPECT_EQ(r.hits[0].t, 10.0 * scale);
            EXPECT_EQ(r.hits[1].object, 19u);
            EXPECT_EQ(r.hits[1].t, 71.0 * scale);
        }
    }
}

TEST(EmbreeAccel, QueryEngineSkipsTheBvhForTinyScenes) {
    auto tiny = QueryEngine::build(std::make_shared<Scene>(testing::tutorial_spheres()));
    ASSERT_TRUE(tiny.ok());
    EXPECT_TRUE((*tiny)->brute_force());
    EXPECT_EQ((*tiny)->effective_precision(Precision::fast), Precision::exact);
    auto big = QueryEngine::build(std::make_shared<Scene>(testing::random_scene(3)));
    ASSERT_TRUE(big.ok());
    EXPECT_FALSE((*big)->brute_force());
    EXPECT_EQ((*big)->effective_precision(Precision::fast), Precision::fast);
}

}  // namespace
}  // namespace raycastd::engine
