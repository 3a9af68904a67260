// Tracer and QueryEngine's single-ray calls: the same answers as a batch of one ray, the shadow
// rule for refined, and a scan of its own for many rays over a scene answered by brute force.

#include "engine/query/tracer.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

std::shared_ptr<const QueryEngine> build(Scene s) {
    auto e = QueryEngine::build(std::make_shared<Scene>(std::move(s)));
    EXPECT_TRUE(e.ok());
    return *e;
}

std::vector<Ray> some_rays(std::uint64_t seed, int n) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> pos(-8, 8), dir(-1, 1);
    std::vector<Ray> rays;
    for (int i = 0; i < n; ++i) {
        Ray r;
        r.origin = {pos(rng), pos(rng), pos(rng)};
        r.direction = {dir(rng), dir(rng), dir(rng) + 1e-3};
        rays.push_back(r);
    }
    return rays;
}

/// The same hit, bit for bit where it is compared.
void expect_same(const Hit& got, const Hit& want) {
    EXPECT_EQ(got.object, want.object);
    EXPECT_EQ(got.primitive, want.primitive);
    EXPECT_EQ(got.t, want.t);
    EXPECT_EQ(got.normal, want.normal);
    EXPECT_EQ(got.front_face, want.front_face);
}

// Batches too: closest_batch as intersect(), and occluded_batch's bytes as intersect()'s `any`
// answers, over more than two of its blocks of 1,024 rays (traced in parallel), on a BVH and by
// brute force.
TEST(Tracer, SingleRaysAnswerAsABatchOfOne) {
    for (const Scene& s : {testing::random_scene(11), testing::tutorial_spheres()}) {
        auto engine = build(s);
        for (Precision p : {Precision::fast, Precision::refined, Precision::exact}) {
            const Tracer tracer(*engine, p, BuildHint::few_rays);
            EXPECT_EQ(tracer.precision(), engine->effective_precision(p));
            const std::vector<Ray> rays = some_rays(12, 2500);
            const QueryResult closest = engine->intersect(rays, QueryOptions{Mode::closest, p});
            const QueryResult any = engine->intersect(rays, QueryOptions{Mode::any, p});
            std::vector<Hit> batch;
            tracer.closest_batch(rays, batch);
            ASSERT_EQ(batch.size(), rays.size());
            std::vector<std::uint8_t> blocked(7, 2);  // resized, every byte written
            tracer.occluded_batch(rays, blocked);
            ASSERT_EQ(blocked.size(), rays.size());
            int hits = 0;
            for (std::size_t i = 0; i < rays.size(); ++i) {
                const bool one_blocked = engine->occluded(rays[i], p);
                EXPECT_EQ(any.hits[i].valid(), one_blocked) << i;
                EXPECT_EQ(blocked[i], one_blocked ? 1 : 0) << i;
                EXPECT_EQ(tracer.occluded(rays[i]), one_blocked) << i;
                hits += one_blocked;
            }
            EXPECT_GT(hits, 40);  // 62 on the tutorial's spheres
            EXPECT_LT(hits, 2400);
            for (std::size_t i = 0; i < rays.size(); ++i) {
                const std::optional<Hit> one = engine->closest(rays[i], p, true);
                ASSERT_EQ(one.has_value(), closest.hits[i].valid()) << i;
                if (one)
                    expect_same(*one, closest.hits[i]);
                const std::optional<Hit> traced = tracer.closest(rays[i], true);
                ASSERT_EQ(traced.has_value(), one.has_value());
                if (traced)
                    expect_same(*traced, *one);
                expect_same(batch[i], closest.hits[i]);
            }
        }
    }
}

// refined's shadow rays (QueryEngine::occluded, one refined traversal since issue 17) agree
// with exact's.
TEST(Tracer, RefinedShadowRaysAgreeWithExact) {
    auto engine = build(testing::random_scene(13));
    ASSERT_FALSE(engine->brute_force());
    const std::vector<Ray> rays = some_rays(14, 2000);
    const QueryResult exact = engine->intersect(rays, QueryOptions{Mode::any, Precision::exact});
    const Tracer tracer(*engine, Precision::refined, BuildHint::few_rays);
    int hits = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        EXPECT_EQ(engine->occluded(rays[i], Precision::refined), exact.hits[i].valid()) << i;
        EXPECT_EQ(tracer.occluded(rays[i]), exact.hits[i].valid()) << i;
        hits += exact.hits[i].valid();
    }
    EXPECT_GT(hits, 100);
}

// A scene of at most 16 primitives is answered by brute force (exact); a tracer for many rays
// scans it through a copy of its own: at refined and exact the same answers bit for bit, at
// fast the fast kernels (within their bounds), all decided in double (no float frame).
TEST(Tracer, ManyRaysScanATinyScene) {
    const Scene s = testing::tutorial_spheres();
    auto engine = build(s);
    ASSERT_TRUE(engine->brute_force());
    for (Precision p : {Precision::fast, Precision::refined, Precision::exact}) {
        const Tracer few(*engine, p, BuildHint::few_rays);
        EXPECT_FALSE(few.scans());
        EXPECT_EQ(few.precision(), Precision::exact);
        EXPECT_EQ(few.float_frame().scale, 0.0);
        const Tracer many(*engine, p, BuildHint::many_rays);
        EXPECT_TRUE(many.scans());
        EXPECT_EQ(many.precision(), p == Precision::fast ? p : Precision::exact);
        EXPECT_EQ(many.float_frame().scale, 0.0);
        const std::vector<Ray> rays = some_rays(15, 5000);
        std::vector<Hit> batch;
        std::vector<std::uint8_t> blocked;
        many.closest_batch(rays, batch);
        many.occluded_batch(rays, blocked);
        int hits = 0;
        for (std::size_t i = 0; i < rays.size(); ++i) {
            const std::optional<Hit> want = few.closest(rays[i], true);
            const std::optional<Hit> got = many.closest(rays[i], true);
            ASSERT_EQ(got.has_value(), want.has_value());
            EXPECT_EQ(many.occluded(rays[i]), few.occluded(rays[i]));
            EXPECT_EQ(blocked[i], few.occluded(rays[i]) ? 1 : 0);
            ASSERT_EQ(batch[i].valid(), got.has_value());
            if (!got)
                continue;
            ++hits;
            expect_same(batch[i], *got);
            if (p != Precision::fast) {
                expect_same(*got, *want);
                continue;
            }
            EXPECT_EQ(got->object, want->object);
            EXPECT_NEAR(got->t, want->t, got->t_err + want->t_err);
        }
        EXPECT_GT(hits, 100);
    }
}

// A scene of four triangles wider than float can hold (±1e39) is brute force too, and a tracer
// for many rays scans it in double (a BVH of Embree's would see infinities and miss).
TEST(Tracer, ManyRaysScanATinySceneWiderThanFloat) {
    Scene s;
    s.materials.push_back(Material{});
    for (int i = 0; i < 4; ++i) {
        const double x = i % 2 ? 1e39 : -1e39;
        const double z = 10.0 + i;
        s.objects.push_back(testing::mesh_object(
            "t" + std::to_string(i), {{x - 1e30, -1e30, z}, {x + 1e30, -1e30, z}, {x, 1e30, z}},
            {{0, 1, 2}}));
    }
    auto engine = build(s);
    for (Precision p : {Precision::fast, Precision::refined}) {
        const Tracer tracer(*engine, p, BuildHint::many_rays);
        EXPECT_TRUE(tracer.scans());
        EXPECT_EQ(tracer.float_frame().scale, 0.0);
        const std::optional<Hit> h = tracer.closest(Ray{{-1e39, 0, 0}, {0, 0, 1}}, true);
        ASSERT_TRUE(h) << to_string(p);
        EXPECT_EQ(h->object, 0u);
        EXPECT_NEAR(h->t, 10.0, h->t_err);
        if (p != Precision::fast) {
            EXPECT_EQ(h->t, 10.0);
        }
    }
}

// A far ray through a scanned scene is answered as QueryEngine's brute force answers it (moved
// to the scene, accel/far_ray.h): the scan's own kernels, deciding on the far ray, err by
// ~u·distance, and from 2^66 away a ray through a triangle at `fast` hit the sphere 7.7 units
// behind it instead (a helper's review). Lines from 2^30 to 2^90 away, straight through the
// triangle and then the sphere, or through the sphere alone.
TEST(Tracer, ManyRaysAnswerFarRaysAsTheBruteForce) {
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(
        testing::mesh_object("tri", {{-1, -1, 0}, {1, -1, 0}, {0, 1, 0}}, {{0, 1, 2}}));
    s.objects.push_back(testing::sphere("ball", {5, 5, 5}, 1, 0));
    auto engine = build(s);
    ASSERT_TRUE(engine->brute_force());
    std::vector<Ray> rays;
    for (int e = 30; e <= 90; e += 12) {
        const double far = std::ldexp(1.0, e);
        rays.push_back(Ray{{-far, -far, -far}, {1, 1, 1}});  // triangle, then ball
        rays.push_back(Ray{{5, 5, -far}, {0, 0, 3}});        // ball only
    }
    for (Precision p : {Precision::fast, Precision::refined}) {
        const Tracer few(*engine, p, BuildHint::few_rays);
        const Tracer many(*engine, p, BuildHint::many_rays);
        ASSERT_TRUE(many.scans());
        std::vector<Hit> batch;
        std::vector<std::uint8_t> blocked;
        many.closest_batch(rays, batch);
        many.occluded_batch(rays, blocked);
        for (std::size_t i = 0; i < rays.size(); ++i) {
            SCOPED_TRACE(std::string(to_string(p)) + ", ray " + std::to_string(i));
            const std::optional<Hit> got = many.closest(rays[i], true);
            ASSERT_TRUE(got);
            EXPECT_EQ(got->object, i % 2 == 0 ? 0u : 1u);
            expect_same(*got, *few.closest(rays[i], true));
            expect_same(batch[i], *got);
            EXPECT_TRUE(many.occluded(rays[i]));
            EXPECT_EQ(blocked[i], 1);
        }
        // A line from 2^50 away that passes 0.25 beside the triangle's edge (x = 0.5 at y = 0;
        // the far kernels err by ~u·2^50 = 0.125 there) and then through the ball.
        const Ray beside{{0.75 - 0x1p50, -0x1p50, -0x1p50}, {1, 1, 1}};
        const std::optional<Hit> got = many.closest(beside, true);
        ASSERT_TRUE(got);
        EXPECT_EQ(got->object, 1u);
        EXPECT_EQ(got->object, few.closest(beside, true)->object);
    }
}

TEST(Tracer, FloatFrameIsEmbreesOnABvhAndNoneInDouble) {
    const Scene s = testing::random_scene(16, 1e6);
    auto engine = build(s);
    ASSERT_FALSE(engine->brute_force());
    EXPECT_EQ(engine->float_frame(Precision::exact).scale, 0.0);
    for (Precision p : {Precision::fast, Precision::refined}) {
        EXPECT_EQ(engine->float_frame(p).center, s.bounds().center());
        EXPECT_GE(engine->float_frame(p).scale, 2.0 * length(s.bounds().diagonal()));
    }
}

TEST(Query, ClosestByBruteForceIsTheExactAnswer) {
    const Scene s = testing::random_scene(17);
    auto engine = build(s);
    for (const Ray& ray : some_rays(18, 500)) {
        const std::optional<Hit> want = engine->closest(ray, Precision::exact, true);
        const std::optional<Hit> got = closest_by_brute_force(s, ray, true);
        ASSERT_EQ(got.has_value(), want.has_value());
        if (!got)
            continue;
        expect_same(*got, *want);
        const std::optional<Hit> in_object =
            closest_in_object_by_brute_force(s, got->object, ray, true);
        ASSERT_TRUE(in_object);
        expect_same(*in_object, *got);
    }
}

}  // namespace
}  // namespace raycastd::engine
