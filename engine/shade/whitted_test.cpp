#include "engine/shade/whitted.h"

#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

std::shared_ptr<const QueryEngine> prepare(Scene s) {
    auto built = QueryEngine::build(std::make_shared<const Scene>(std::move(s)));
    EXPECT_TRUE(built.ok()) << built.status().message;
    return *built;
}

using testing::ambient_light;
using testing::point_light;
using testing::sphere;

// The shape of the tutorial's Question 2: five points where intensity is computed, full Phong
// at I1–I3 and ambient only at I4–I5, whose shadow rays are blocked. The eye is at the origin
// looking along +z; one point light L = (0, 3, 0) and an ambient light.
//
//   object 0 "glass"  sphere (0,0,10) r 2, reflectivity 0.2, transparency 0.7, ior 1.5
//   object 1 "mirror" triangle (−3,−1,−6) (3,−1,−6) (0,2,−3): the plane −y + z = −5, normal
//                     (b−a)×(c−a) = (0,−18,18) ∝ (0,−1,1); reflectivity 0.8
//   object 2 "ball"   sphere (0,−6,−5) r 1, matte
//   object 3 "back"   sphere (0,0,20) r 2, matte
//
// The ray tree of the ray (0,0,0) + t·(0,0,1), derived by hand:
//   I1 = (0,0,8) on glass (t = 8, normal (0,0,−1)). L − I1 = (0,3,−8) is in front of the normal;
//        the segment (0, 3s, 8 − 8s) stays outside glass (|(0,3s,−2−8s)|² > 4 for s > 0) and
//        meets nothing else: lit, full Phong.
//     reflected: normal incidence sends it back along −z; it meets the mirror's plane at z = −5,
//        at (0,0,−5), inside the triangle (the point is a + (3,1,1)·1/… : at height 1 of 3 the
//        triangle spans x ∈ [−2, 2]).
//   I2 = (0,0,−5) on mirror. Normal facing the ray (0,−1,1)/√2; L − I2 = (0,3,5) gives N·L > 0;
//        the segment (0, 3s, −5 + 5s) has z ≤ 0 (no glass, no back) and y ≥ 0 (no ball): lit.
//     reflected: d − 2(d·n)n with d = (0,0,−1), n = (0,−1,1)/√2 gives (0,−1,0): along −y it meets
//        ball's top at (0,−5,−5).
//   I3 = (0,−5,−5) on ball, normal (0,1,0). L − I3 = (0,8,5), N·L > 0; the segment
//        (0, −5 + 8s, −5 + 5s) meets the mirror's plane only at s = 5/3 > 1, and nothing else:
//        lit. Matte: no children.
//     refracted (from I1): normal incidence, no bending: along +z inside glass to its far side.
//   I4 = (0,0,12) on glass, leaving it: the normal turned to the ray is (0,0,−1); L − I4 =
//        (0,3,−12) is in front of it, but the segment (0, 3s, 12 − 12s) runs inside glass until
//        s = 48/153: blocked by glass itself, ambient only. Internal reflection is not traced;
//        refraction out, still at normal incidence, goes on along +z.
//   I5 = (0,0,18) on back, normal (0,0,−1). L − I5 = (0,3,−18) is in front, but the segment
//        (0, 3s, 18 − 18s) passes through glass for s ∈ (0.350, 0.515) (333s² − 288s + 60 < 0):
//        blocked by glass (a transparent object blocks, as in the classic model): ambient only.
// Depth-first, reflected before refracted: I1 glass, I2 mirror, I3 ball, I4 glass, I5 back.
Scene tutorial_q2_scene() {
    Scene s;
    s.materials = {Material{}, Material{}, Material{}};
    s.material_names = {"default", "glass", "mirror"};
    s.materials[1].reflectivity = 0.2;
    s.materials[1].transparency = 0.7;
    s.materials[1].ior = 1.5;
    s.materials[2].reflectivity = 0.8;
    s.objects.push_back(sphere("glass", {0, 0, 10}, 2, 1));
    Object mirror =
        testing::mesh_object("mirror", {{-3, -1, -6}, {3, -1, -6}, {0, 2, -3}}, {{0, 1, 2}});
    mirror.material = 2;
    s.objects.push_back(mirror);
    s.objects.push_back(sphere("ball", {0, -6, -5}, 1, 0));
    s.objects.push_back(sphere("back", {0, 0, 20}, 2, 0));
    s.lights = {ambient_light(0.2), point_light({0, 3, 0})};
    return s;
}

TEST(Whitted, TutorialQuestion2Tree) {
    auto engine = prepare(tutorial_q2_scene());
    const Whitted w(*engine, {});
    const RayTree t = w.tree(Ray{{0, 0, 0}, {0, 0, 1}}).value();
    ASSERT_EQ(t.nodes.size(), 5u);
    const std::uint32_t objects[5] = {0, 1, 2, 0, 3};
    const bool full[5] = {true, true, true, false, false};
    for (int k = 0; k < 5; ++k) {
        SCOPED_TRACE("I" + std::to_string(k + 1));
        EXPECT_EQ(t.nodes[k].hit.object, objects[k]);
        EXPECT_EQ(t.nodes[k].full_phong, full[k]);
        ASSERT_EQ(t.nodes[k].shadow_rays.size(), 1u);
        EXPECT_EQ(t.nodes[k].shadow_rays[0].light, 1u);
        EXPECT_TRUE(t.nodes[k].shadow_rays[0].facing);
        EXPECT_EQ(t.nodes[k].shadow_rays[0].blocked_by, full[k] ? kInvalidId : 0u);
    }
    // The structure: I1 → reflected I2 → reflected I3; I1 → refracted I4 → refracted I5.
    EXPECT_EQ(t.nodes[0].reflected, 1);
    EXPECT_EQ(t.nodes[0].refracted, 3);
    EXPECT_EQ(t.nodes[1].reflected, 2);
    EXPECT_EQ(t.nodes[1].refracted, -1);
    EXPECT_EQ(t.nodes[3].reflected, -1);  // internal reflection is not traced
    EXPECT_EQ(t.nodes[3].refracted, 4);
    EXPECT_NEAR(t.nodes[0].point.z, 8.0, 1e-12);
    EXPECT_NEAR(t.nodes[1].point.z, -5.0, 1e-9);
    EXPECT_NEAR(t.nodes[2].point.y, -5.0, 1e-9);
    EXPECT_NEAR(t.nodes[3].point.z, 12.0, 1e-9);
    EXPECT_NEAR(t.nodes[4].point.z, 18.0, 1e-9);
    // Normals face the incoming ray: the glass exit point I4 is shaded from inside.
    EXPECT_NEAR(t.nodes[3].normal.z, -1.0, 1e-12);
    // Ambient-only points: ka·Ia = 0.1 · 0.2.
    EXPECT_NEAR(t.nodes[4].color.x, 0.02, 1e-12);
    // I3: ka·Ia + kd·(N·L) + ks·(R·V)ⁿ with N = (0,1,0), L = (0,8,5)/√89, V = (0,1,0), R·V = N·L.
    const double nl = 8 / std::sqrt(89.0);
    EXPECT_NEAR(t.nodes[2].color.x, 0.02 + 0.7 * nl + 0.2 * std::pow(nl, 32), 1e-9);
    // I1's colour is its own terms plus 0.2·I2 + 0.7·I4.
    EXPECT_EQ(t.color, t.nodes[0].color);
    EXPECT_EQ(t.counts.primary, 1u);
    EXPECT_EQ(t.counts.shadow, 5u);
    EXPECT_EQ(t.counts.reflected, 2u);
    EXPECT_EQ(t.counts.refracted, 2u);
}

TEST(Whitted, RadianceIsTheTreesColourWithTheSameRays) {
    auto engine = prepare(tutorial_q2_scene());
    const Whitted w(*engine, {});
    const Ray ray{{0, 0, 0}, {0, 0, 1}};
    RayCounts counts;
    const Vec3d c = w.radiance(ray, counts);
    const RayTree t = w.tree(ray).value();
    EXPECT_EQ(c, t.color);
    EXPECT_EQ(counts.total(), t.counts.total());
}

TEST(Whitted, MaxDepthCutsTheTree) {
    auto engine = prepare(tutorial_q2_scene());
    WhittedOptions o;
    o.max_depth = 2;
    EXPECT_EQ(Whitted(*engine, o).tree(Ray{{0, 0, 0}, {0, 0, 1}}).value().nodes.size(),
              3u);  // I1 I2 I4
    o.max_depth = 1;
    EXPECT_EQ(Whitted(*engine, o).tree(Ray{{0, 0, 0}, {0, 0, 1}}).value().nodes.size(), 1u);
}

TEST(Whitted, TreeStopsWhenItsTokenHasFired) {
    auto engine = prepare(tutorial_q2_scene());
    const Whitted w(*engine, {});
    const Ray ray{{0, 0, 0}, {0, 0, 1}};
    const CancelToken stopped = CancelToken::make();
    stopped.cancel();
    const auto t = w.tree(ray, stopped);
    ASSERT_FALSE(t.ok());
    EXPECT_EQ(t.status().code, Code::cancelled);
    // A token that could fire but does not changes nothing.
    const CancelToken armed = CancelToken::make(CancelToken::Clock::now() + std::chrono::hours(1));
    const RayTree a = w.tree(ray, armed).value();
    const RayTree b = w.tree(ray).value();
    EXPECT_EQ(a.nodes.size(), b.nodes.size());
    EXPECT_EQ(a.color, b.color);
}

TEST(Whitted, MissGivesAnEmptyTreeAndTheBackground) {
    auto engine = prepare(tutorial_q2_scene());
    WhittedOptions o;
    o.background = {0.25, 0.5, 1};
    const RayTree t = Whitted(*engine, o).tree(Ray{{0, 0, 0}, {1, 0, 0}}).value();
    EXPECT_TRUE(t.nodes.empty());
    EXPECT_EQ(t.color, o.background);
}

TEST(Whitted, LightBehindTheShadingNormalIsNotFacingAndTracesNoRay) {
    Scene s = testing::tutorial_spheres();
    s.lights = {point_light({0, 0, 30})};  // behind sphere 3 as seen from the eye
    auto engine = prepare(std::move(s));
    const RayTree t = Whitted(*engine, {}).tree(Ray{{0, 0, 0}, {0, 0, 1}}).value();
    ASSERT_EQ(t.nodes.size(), 1u);
    EXPECT_FALSE(t.nodes[0].shadow_rays[0].facing);
    EXPECT_EQ(t.nodes[0].shadow_rays[0].blocked_by, kInvalidId);
    EXPECT_FALSE(t.nodes[0].full_phong);
    EXPECT_EQ(t.counts.shadow, 0u);
}

/// The ray tree of `r` by both tracers (for many rays, a scan of a small scene; QueryEngine's
/// own path for few) at fast and refined: its first hit on object 0, at `want` within `tol`
/// where given, and fully lit by the scene's one point light; and the same colour through a
/// render's paths, radiance() (occluded shadow rays) and shade_hits() (their batches).
void expect_lit_first_hit(const QueryEngine& engine, const Ray& r, const Vec3d* want, double tol) {
    for (bool many : {false, true}) {
        for (Precision precision : {Precision::fast, Precision::refined}) {
            SCOPED_TRACE(std::string(many ? "many rays, " : "") + to_string(precision));
            WhittedOptions o;
            o.many_rays = many;
            o.precision = precision;
            const Whitted w(engine, o);
            const RayTree t = w.tree(r).value();
            RayCounts counts;
            EXPECT_LE(max_abs(w.radiance(r, counts) - t.color), 1e-9);
            std::vector<Hit> hits;
            std::vector<Vec3d> colors;
            w.closest_batch({r}, hits);
            w.shade_hits({r}, hits, colors, counts);
            ASSERT_EQ(colors.size(), 1u);
            EXPECT_LE(max_abs(colors[0] - t.color), 1e-9);
            ASSERT_FALSE(t.nodes.empty());
            EXPECT_EQ(t.nodes[0].hit.object, 0u);
            if (want) {
                EXPECT_LE(max_abs(t.nodes[0].point - *want), tol);
            }
            ASSERT_EQ(t.nodes[0].shadow_rays.size(), 1u);
            EXPECT_TRUE(t.nodes[0].shadow_rays[0].facing);
            EXPECT_EQ(t.nodes[0].shadow_rays[0].blocked_by, kInvalidId);
            EXPECT_TRUE(t.nodes[0].full_phong);
        }
    }
}

// A ray from far away is shaded at its point on the surface, not at o + t·d, which rounds by
// u·|o|: from 2^66 away along (1, 1, 1) the hit on the plane x + 2y + 4z = 1 at (1/7, 1/7, 1/7)
// came out as (0, 0, 0), 0.22 behind the plane, and a light 0.1 in front of it was judged to be
// behind it (`facing` false: a helper's review). At 2^40 the sum is off by 3.5e-5.
TEST(Whitted, FarRaysAreShadedAtTheirPointOnTheSurface) {
    Scene s;
    s.materials = {Material{}};
    s.objects.push_back(
        testing::mesh_object("tilted", {{1, 0, 0}, {-3, 0, 1}, {1, 2, -1}}, {{0, 1, 2}}));
    s.objects.push_back(sphere("behind", {5, 5, 5}, 1, 0));
    const Vec3d n = Vec3d{1, 2, 4} / std::sqrt(21.0);
    const Vec3d p{1.0 / 7, 1.0 / 7, 1.0 / 7};
    s.lights = {ambient_light(0.2), point_light(p - n * 0.1)};
    auto engine = prepare(std::move(s));
    // 2^26: more than 2^20 of the triangle's size away, but near enough for a render's scan to
    // answer itself (SceneBall::far from ~2^29.8 for this scene); its point is then the scan's
    // barycentric one, off by ~u·distance/size of the triangle's size.
    for (double far : {0x1p26, 0x1p40, 0x1p66}) {
        SCOPED_TRACE("from " + std::to_string(far));
        expect_lit_first_hit(*engine, Ray{{-far, -far, -far}, {1, 1, 1}}, &p,
                             far < 0x1p27 ? 1e-7 : 1e-15);
    }
}

// The same for a triangle in the plane z = 0, whose point has no rounding across that plane:
// spawned with an offset of 0, the shadow ray started on the triangle and was blocked by it at
// t = 0, and a far camera's render showed the lit triangle black (seen in a render through the
// server, 2026-12-06). A light 1e17 away along the normal tests the size of the bound's floor:
// the least normal double alone gave a shadow ray's t = that offset over |direction| ≈ 1e17,
// which underflowed to −0 and passed tmin = 0 (a review). With an icosphere far off the scene
// has a BVH (Embree, whose float error the spawned origins add) instead of a scan.
TEST(Whitted, FarRaysOnAnAxisAlignedTriangleAreLit) {
    for (bool bvh : {false, true}) {
        for (const Vec3d& light : {Vec3d{0, 2, -10}, Vec3d{0, 2, -1e17}}) {
            Scene s;
            s.materials = {Material{}};
            s.objects.push_back(
                testing::mesh_object("flat", {{-1, -1, 0}, {1, -1, 0}, {0, 1, 0}}, {{0, 1, 2}}));
            s.objects.push_back(sphere("behind", {0, 0, 5}, 2, 0));
            if (bvh)
                s.objects.push_back(testing::icosphere_object(1, {40, 40, 40}, 1.0));
            s.lights = {ambient_light(0.2), point_light(light)};
            auto engine = prepare(std::move(s));
            ASSERT_EQ(engine->brute_force(), !bvh);
            for (double far : {0x1p26, 0x1p66}) {
                SCOPED_TRACE("from " + std::to_string(far) + (bvh ? ", BVH" : "") +
                             ", light at z = " + std::to_string(light.z));
                // Through (0.0625, −0.125, 0) from 2^66 away.
                expect_lit_first_hit(*engine, Ray{{0, 0, -far}, {0x1p-70, -0x1p-69, 1}}, nullptr,
                                     0.0);
            }
        }
    }
}

TEST(Whitted, TotalInternalReflectionIsReportedAndTransmitsNothing) {
    // A ray leaving a glass cube past the critical angle.
    Scene s;
    s.materials = {Material{}, Material{}};
    s.materials[1].transparency = 1.0;
    s.materials[1].ior = 1.5;
    Object cube = testing::cube_object(-1, 1);
    cube.material = 1;
    s.objects.push_back(cube);
    auto engine = prepare(std::move(s));
    // Start inside the cube and meet the z = 1 face at (0.433, 0, 1), 53° from its normal
    // (cos θ = 0.6): past the critical angle asin(1/1.5) = 41.8°.
    const Ray r{{-0.9, 0, 0}, {0.8, 0, 0.6}};
    const RayTree t = Whitted(*engine, {}).tree(r).value();
    ASSERT_FALSE(t.nodes.empty());
    EXPECT_TRUE(t.nodes[0].total_internal_reflection);
    EXPECT_EQ(t.nodes[0].refracted, -1);
    EXPECT_EQ(t.nodes[0].reflected, -1);
}

// shade_hits() (batches, the renderer's path) against shade_hit() (one hit at a time) at exact,
// where both decide every ray in double: the same colours, bit for bit, compared in double (a
// float image would hide a last-bit difference). A light 1e200 away takes normalize()'s
// rescaling branch. Mutants of a four-at-a-time direction to the point lights (tried
// 2026-12-07, docs/rendering.md) that multiplied by 1/|v| instead of dividing, or skipped the
// rescaling, failed here.
TEST(Whitted, BatchesShadeAsOneHitAtATimeBitForBit) {
    Scene s;
    s.materials = {Material{}, Material{}};
    s.materials[0].specular = {0.5, 0.5, 0.5};
    s.materials[1].reflectivity = 0.3;
    s.objects.push_back(testing::icosphere_object(3, {0, 0, 0}, 1.0));
    s.objects.push_back(testing::icosphere_object(2, {2.5, 0.3, 0.5}, 0.8));
    s.objects.back().material = 1;
    s.lights = {ambient_light(0.1), point_light({3, 4, -5}), point_light({-2, 1, -3}),
                point_light(Vec3d{-1, 2, -2} * 1e200)};
    auto engine = prepare(std::move(s));
    ASSERT_FALSE(engine->brute_force());
    WhittedOptions o;
    o.precision = Precision::exact;
    const Whitted w(*engine, o);
    std::vector<Ray> rays;
    for (int y = 0; y < 40; ++y) {
        for (int x = 0; x < 61; ++x)  // 61: a batch that is not a multiple of four
            rays.push_back(Ray{{0.5, 0.2, -6}, {(x - 30) * 0.013, (y - 20) * 0.011, 1}});
    }
    std::vector<Hit> hits;
    w.closest_batch(rays, hits);
    std::vector<Vec3d> colors;
    RayCounts batched;
    w.shade_hits(rays, hits, colors, batched);
    ASSERT_EQ(colors.size(), rays.size());
    RayCounts single;
    int shaded = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        if (!hits[i].valid())
            continue;
        ++shaded;
        const Vec3d c = w.shade_hit(rays[i], hits[i], single);
        EXPECT_EQ(colors[i], c) << i;
    }
    EXPECT_GT(shaded, 800);  // 936
    EXPECT_EQ(batched.shadow, single.shadow);
    EXPECT_GT(batched.shadow, 2000u);
    EXPECT_GT(batched.reflected, 50u);
    // Batches reuse their buffers (engine/thread_scratch.h): a later, smaller batch in another
    // order, over what the first left there, gets the same colours.
    std::vector<Ray> later(rays.rbegin() + 300, rays.rend());
    std::vector<Hit> later_hits(hits.rbegin() + 300, hits.rend());
    std::vector<Vec3d> later_colors;
    w.shade_hits(later, later_hits, later_colors, batched);
    ASSERT_EQ(later_colors.size(), later.size());
    for (std::size_t i = 0; i < later.size(); ++i)
        EXPECT_EQ(later_colors[i], colors[rays.size() - 301 - i]) << i;
}

TEST(Whitted, PlanSkipsWhatTheSceneDoesNotNeed) {
    Scene s = testing::tutorial_spheres();
    s.materials[0].specular = {0, 0, 0};
    {
        auto engine = prepare(s);
        const ShadingPlan p = plan_shading(engine->scene());
        EXPECT_TRUE(p.shadow_lights.empty());
        EXPECT_FALSE(p.reflection);
        EXPECT_FALSE(p.refraction);
        EXPECT_FALSE(p.specular[0]);
        EXPECT_EQ(p.ambient, Vec3d(1, 1, 1));  // no lights: ambient 1.0 only
    }
    s.lights = {ambient_light(0.3)};
    auto engine = prepare(s);
    EXPECT_EQ(plan_shading(engine->scene()).ambient, Vec3d(0.3, 0.3, 0.3));
}

TEST(Whitted, MeshesWithoutNormalsAreShadedWithComputedOnes) {
    // A coarse icosphere (80 faces) from a "file" without normals, seen along +z: the shading
    // normal is the area-weighted vertex normals interpolated, much nearer the true sphere's
    // radius than the faceted geometric normal, which intersect keeps reporting. A cube keeps
    // its creases: its shading normal is the face's. The normals are computed on first use
    // and counted in memory_bytes.
    Scene s;
    s.materials.push_back(Material{});
    s.objects.push_back(testing::icosphere_object(1, {0, 0, 5}, 1.0));
    s.objects.push_back(testing::cube_object(3, 4));
    auto engine = prepare(std::move(s));
    const std::size_t bytes_before = engine->memory_bytes();
    const Whitted w(*engine, WhittedOptions{});
    EXPECT_GT(engine->memory_bytes(), bytes_before);
    double smooth = 0, faceted = 0;
    int hits = 0;
    for (int i = -8; i <= 8; ++i) {
        for (int j = -8; j <= 8; ++j) {
            Ray r;
            r.origin = {0.1 * i, 0.1 * j, 0};
            r.direction = {0, 0, 1};
            const std::optional<Hit> h = w.closest(r);
            if (!h)
                continue;
            ++hits;
            const Vec3d radius = normalize(r.at(h->t) - Vec3d{0, 0, 5});
            EXPECT_NEAR(length(w.shading_normal(*h)), 1.0, 1e-6);
            smooth += std::acos(std::min(1.0, dot(w.shading_normal(*h), radius)));
            faceted += std::acos(std::min(1.0, dot(h->normal, radius)));
            const Triangle tri = engine->scene().objects[0].mesh->triangle(h->primitive);
            EXPECT_LT(length(h->normal - triangle_normal(tri)), 1e-6);  // intersect: geometric
        }
    }
    ASSERT_GT(hits, 100);
    EXPECT_LT(smooth, 0.5 * faceted);
    Ray r;
    r.origin = {3.5, 3.5, -1};
    r.direction = {0, 0, 1};
    const std::optional<Hit> cube = w.closest(r);
    ASSERT_TRUE(cube);
    EXPECT_LT(length(w.shading_normal(*cube) - Vec3d{0, 0, -1}), 1e-6);
}

TEST(Whitted, TextureColourMultipliesDiffuseAmbientAndAMetalsSpecular) {
    // A quad at z = 5 (two triangles) whose texture is a red texel left of u = 0.5 and a blue
    // one right of it (nearest), and a scene without lights: ambient 1.0 alone, so the colour
    // is ka · texel, exactly. The corner (u, v) are interpolated with the hit's barycentrics.
    auto image = std::make_shared<TextureImage>();
    image->width = 2;
    image->height = 1;
    image->rgb = {255, 0, 0, 0, 0, 255};
    auto texture = std::make_shared<Texture>();
    texture->image = image;
    texture->nearest = true;
    Scene s;
    s.materials.push_back(Material{});
    Material m;
    m.ambient = {0.5, 1.0, 1.0};
    m.texture = texture;
    s.materials.push_back(m);
    auto mesh = std::make_shared<TriangleMesh>();
    mesh->positions = {{-1, -1, 5}, {1, -1, 5}, {1, 1, 5}, {-1, 1, 5}};
    mesh->triangles = {{0, 1, 2}, {0, 2, 3}};
    // x = −1 → u = 0, x = +1 → u = 1; v = 0 along the top.
    mesh->corner_uvs = {{{{0, 1}, {1, 1}, {1, 0}}}, {{{0, 1}, {1, 0}, {0, 0}}}};
    Object o;
    o.kind = ObjectKind::mesh;
    o.material = 1;
    o.mesh = mesh;
    s.objects.push_back(o);
    auto engine = prepare(std::move(s));
    ASSERT_TRUE(engine->scene().features().textures);
    const Whitted w(*engine, WhittedOptions{});
    auto colour_at = [&](double x, double y) {
        Ray r;
        r.origin = {x, y, 0};
        r.direction = {0, 0, 1};
        RayCounts counts;
        return w.radiance(r, counts);
    };
    EXPECT_EQ(colour_at(-0.5, 0.3), Vec3d(0.5, 0, 0));
    EXPECT_EQ(colour_at(-0.5, -0.7), Vec3d(0.5, 0, 0));
    EXPECT_EQ(colour_at(0.5, 0.6), Vec3d(0, 0, 1));
    EXPECT_EQ(colour_at(0.5, -0.6), Vec3d(0, 0, 1));
    // A metal's reflectance is its base colour (Material::textured_specular): the texture
    // multiplies that share of the specular colour and not the rest. One directional light
    // head-on (N·L = R·V = 1) and no ambient, so the colour is ks, exactly: 0.25 + 1 · texel.
    {
        Scene metal = engine->scene();
        Material& mm = metal.materials[1];
        mm.ambient = mm.diffuse = Vec3d{0, 0, 0};
        mm.specular = {1.25, 1.25, 1.25};
        mm.textured_specular = {1, 1, 1};
        mm.shininess = 1;
        Light light;
        light.type = LightType::directional;
        light.direction = {0, 0, 1};
        light.intensity = {1, 1, 1};
        metal.lights.push_back(light);
        auto shiny = prepare(std::move(metal));
        const Whitted wm(*shiny, WhittedOptions{});
        Ray r;
        r.origin = {-0.5, 0.3, 0};
        r.direction = {0, 0, 1};
        RayCounts counts;
        EXPECT_EQ(wm.radiance(r, counts), Vec3d(1.25, 0.25, 0.25));
        r.origin = {0.5, 0.6, 0};
        EXPECT_EQ(wm.radiance(r, counts), Vec3d(0.25, 0.25, 1.25));
    }
    // Without texture coordinates the texture is not sampled: the material's own colour.
    Scene plain = engine->scene();
    auto bare = std::make_shared<TriangleMesh>(*mesh);
    bare->corner_uvs.clear();
    plain.objects[0].mesh = bare;
    auto untextured = prepare(std::move(plain));
    EXPECT_FALSE(untextured->scene().features().textures);
    Ray r;
    r.origin = {0.5, 0.6, 0};
    r.direction = {0, 0, 1};
    RayCounts counts;
    EXPECT_EQ(Whitted(*untextured, WhittedOptions{}).radiance(r, counts), Vec3d(0.5, 1, 1));
}

}  // namespace
}  // namespace raycastd::engine
