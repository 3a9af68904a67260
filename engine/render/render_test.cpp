#include "engine/render/render.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include "engine/geometry/target_clones.h"
#include "engine/render/camera_rays.h"
#include "engine/render/image.h"
#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

std::shared_ptr<const QueryEngine> prepare(Scene s) {
    auto built = QueryEngine::build(std::make_shared<const Scene>(std::move(s)));
    EXPECT_TRUE(built.ok());
    return *built;
}

Scene lit_spheres(double reflectivity) {
    Scene s = testing::tutorial_spheres();
    s.materials[0].reflectivity = reflectivity;
    Light l;
    l.type = LightType::point;
    l.position = {5, 5, 0};
    s.lights = {l};
    return s;
}

RenderOptions small(ShadingMode mode = ShadingMode::phong) {
    RenderOptions o;
    o.width = 40;
    o.height = 30;
    o.shading = mode;
    o.camera = Camera{};  // the eye of the tutorial, looking along +z
    return o;
}

TEST(Camera, RaysThroughTheCentreAndCorners) {
    Camera c;
    c.fov_y_deg = 90;
    const CameraRays cam(c, 200, 100);
    const Ray centre = cam.ray(100, 50);
    EXPECT_NEAR(centre.direction.z, 1.0, 1e-15);
    // Top edge: 45° up; the right edge: tan = 2 (aspect 2), towards −x (right-handed, y up).
    EXPECT_NEAR(cam.ray(100, 0).direction.y, std::sqrt(0.5), 1e-15);
    const Ray right = cam.ray(200, 50);
    EXPECT_NEAR(right.direction.x / right.direction.z, -2.0, 1e-12);
}

TEST(Camera, RequestThenSceneThenFraming) {
    Scene s = testing::tutorial_spheres();
    Camera asked;
    asked.position = {1, 2, 3};
    EXPECT_EQ(resolve_camera(s, asked, 40, 30).position, asked.position);
    EXPECT_EQ(resolve_camera(s, std::nullopt, 40, 30).look_at, s.bounds().center());
    Camera doc;
    doc.position = {0, 0, -1};
    s.camera = doc;
    EXPECT_EQ(resolve_camera(s, std::nullopt, 40, 30).position, doc.position);
}

/// The distance from point c to the line of `ray`.
double distance_to_line(const Ray& ray, const Vec3d& c) {
    const Vec3d d = normalize(ray.direction);
    const Vec3d v = c - ray.origin;
    return length(v - d * dot(v, d));
}

TEST(Camera, DefaultFramingFillsTheNarrowerFieldOfView) {
    // The bounding sphere (centre and half-diagonal of the bounds) just fills the image: the
    // rays through the middles of the two edges of the narrower side are tangent to it, and
    // those of the wider side pass outside it. Landscape: top and bottom; portrait: left and
    // right.
    const Bounds3 b{{-1, 0, 2}, {3, 1, 4}};
    const Vec3d c = b.center();
    const double r = 0.5 * length(b.diagonal());
    for (const auto& [w, h] : {std::pair{640, 480}, {480, 640}, {300, 300}}) {
        Scene s;
        s.objects.push_back(
            testing::mesh_object("box", {b.lo, b.hi, {b.lo.x, b.hi.y, b.hi.z}}, {{0, 1, 2}}));
        s.materials.push_back(Material{});
        const Camera cam = resolve_camera(s, std::nullopt, w, h);
        EXPECT_EQ(cam.look_at, c);
        const CameraRays rays(cam, w, h);
        const double top = distance_to_line(rays.ray(w / 2.0, 0), c);
        const double left = distance_to_line(rays.ray(0, h / 2.0), c);
        const double narrow = w >= h ? top : left, wide = w >= h ? left : top;
        EXPECT_NEAR(narrow, r, 1e-12 * r) << w << "x" << h;
        EXPECT_GE(wide, r * (1 - 1e-12)) << w << "x" << h;
        EXPECT_NEAR(distance_to_line(rays.ray(w / 2.0, h), c), top, 1e-12 * r);  // centred
    }
}

TEST(Camera, AFlatSceneIsSeenFromAboveNotEdgeOn) {
    // A quad in the xz plane (TwoSidedPlane.gltf, a ground plane): from ±z it is edge-on and the
    // image was black. It is seen from 45° above on the default view's side, at the same
    // distance, and its centre is in the middle of the picture; flat in x, from 45° beside.
    const Bounds3 ground{{-1, 0, -1}, {1, 0, 1}};
    const double dist = length(default_camera({{-1, -1, -1}, {1, 1, 1}}, 1.0,
                                              DefaultView::from_plus_z)
                                   .position) *
                        std::sqrt(2.0 / 3.0);  // the same radius: √2 against √3
    for (const DefaultView view : {DefaultView::from_plus_z, DefaultView::from_minus_z}) {
        const Camera cam = default_camera(ground, 1.0, view);
        EXPECT_EQ(cam.look_at, Vec3d(0, 0, 0));
        EXPECT_NEAR(cam.position.y, dist / std::sqrt(2.0), 1e-12);
        EXPECT_NEAR(cam.position.z, (view == DefaultView::from_plus_z ? 1 : -1) * cam.position.y,
                    1e-12);
        EXPECT_EQ(cam.position.x, 0.0);
        const Ray mid = CameraRays(cam, 40, 40).ray(20, 20);
        EXPECT_NEAR(distance_to_line(mid, cam.look_at), 0.0, 1e-12);
    }
    const Camera wall = default_camera({{0, -1, -1}, {0, 1, 1}}, 1.0, DefaultView::from_plus_z);
    EXPECT_GT(wall.position.x, 0.0);
    EXPECT_NEAR(wall.position.x, wall.position.z, 1e-12);
    EXPECT_EQ(wall.position.y, 0.0);
    // Bounds with height are seen straight from ±z, as before.
    EXPECT_EQ(default_camera({{-1, 0, -1}, {1, 1e-3, 1}}, 1.0, DefaultView::from_plus_z).position.y,
              5e-4);
}

// A scene 1e-20 across is framed as one 1 across, scaled: the distance follows its size (a floor
// of 1e-9 on the radius had put the camera 1e11 sizes away, and the render was black). A point
// (bounds of no size) is seen from 1e-9 / sin(22.5°).
TEST(Camera, TinyScenesAreFramedAtTheirOwnSize) {
    for (double s : {1e-300, 1e-20, 1e-9, 1.0, 1e20, 1e300}) {
        const Camera cam =
            default_camera({{-s, -s, -s}, {s, s, s}}, 1.0, DefaultView::from_minus_z);
        EXPECT_NEAR(-cam.position.z / s, std::sqrt(3.0) / std::sin(M_PI / 8), 1e-12) << s;
    }
    const Camera point = default_camera({{1, 2, 3}, {1, 2, 3}}, 1.0, DefaultView::from_minus_z);
    EXPECT_NEAR(length(point.position - point.look_at), 1e-9 / std::sin(M_PI / 8),
                2e-15);  // ulps of 3
}

TEST(Camera, ModelFilesAreFramedFromTheirFront) {
    // DefaultView::from_plus_z (a model file, whose front faces +z): the same distance on the
    // other side, looking along −z with +y up, so +x is on the right of the picture, as in a
    // glTF viewer. from_minus_z (spheres and triangles, the tutorial's) mirrors it: +x on the
    // left.
    const Bounds3 b{{-1, 0, 2}, {3, 1, 4}};
    const Vec3d c = b.center();
    const Camera back = default_camera(b, 4.0 / 3.0, DefaultView::from_minus_z);
    const Camera front = default_camera(b, 4.0 / 3.0, DefaultView::from_plus_z);
    EXPECT_EQ(front.look_at, c);
    EXPECT_GT(front.position.z, c.z);
    EXPECT_LT(back.position.z, c.z);
    EXPECT_NEAR(front.position.z - c.z, c.z - back.position.z, 1e-12 * c.z);
    EXPECT_EQ(front.position.x, c.x);
    EXPECT_EQ(front.position.y, c.y);
    EXPECT_GT(CameraRays(front, 40, 30).ray(40, 15).direction.x, 0.0);
    EXPECT_LT(CameraRays(back, 40, 30).ray(40, 15).direction.x, 0.0);

    // Spheres and lone triangles (the tutorial's kind of scene) are seen from −z; a mesh (a
    // model file) among them turns the scene to +z.
    Scene s = testing::tutorial_spheres();
    s.objects.push_back(
        testing::mesh_object("floor", {{-9, -3, 0}, {9, -3, 0}, {0, -3, 20}}, {{0, 1, 2}}));
    EXPECT_EQ(s.default_view(), DefaultView::from_minus_z);
    EXPECT_LT(resolve_camera(s, std::nullopt, 40, 30).position.z, s.bounds().center().z);
    s.objects.push_back(testing::cube_object(1, 2));
    EXPECT_EQ(s.default_view(), DefaultView::from_plus_z);
    EXPECT_GT(resolve_camera(s, std::nullopt, 40, 30).position.z, s.bounds().center().z);
    Camera own;  // the scene's own camera wins over either side
    own.position = {0, 0, -1};
    s.camera = own;
    EXPECT_EQ(resolve_camera(s, std::nullopt, 40, 30).position, own.position);
}

TEST(Camera, AimAtMovesLookAtAlongTheAxisToTheTarget) {
    // A glTF camera's look_at (one unit ahead) goes where its axis passes closest to the
    // scene's centre: the view direction stays, the pivot is in the scene.
    Camera c;
    c.position = {1, 2, 3};
    c.look_at = c.position + normalize(Vec3d{1, 1, 1});
    const Vec3d forward = normalize(c.look_at - c.position);
    Camera aimed = c;
    aim_at(aimed, {11, 12, 15}, 2.0);
    EXPECT_NEAR(dot(Vec3d{11, 12, 15} - aimed.look_at, forward), 0.0, 1e-12);
    EXPECT_NEAR(length(aimed.look_at - c.position), 32.0 / std::sqrt(3.0), 1e-12);
    const Vec3d now = normalize(aimed.look_at - aimed.position);
    EXPECT_NEAR(length(now - forward), 0.0, 1e-15);
    EXPECT_TRUE(has_view(aimed));
    // A target behind the camera, or less than a thousandth of the radius ahead: unchanged.
    for (const Vec3d& target : {Vec3d{-9, -8, -7}, c.position + forward * 1e-4}) {
        Camera same = c;
        aim_at(same, target, 1.0);
        EXPECT_EQ(same.look_at, c.look_at);
    }
    // No view: look_at on the position, up along the view.
    Camera none = c;
    none.look_at = none.position;
    EXPECT_FALSE(has_view(none));
    none = c;
    none.up = none.look_at - none.position;
    EXPECT_FALSE(has_view(none));
}

// A camera whose look_at is 1e-300 from its position, or 1e300, sees along that direction: its
// rays are unit and finite (normalize() rescales such vectors).
TEST(Render, CameraRaysAtExtremeViewLengths) {
    for (double len : {1e-300, 1.0, 1e300}) {
        Camera c;
        c.position = {0, 0, 0};
        c.look_at = Vec3d{1, 0, 1} * len;
        c.up = {0, 1, 0};
        const Ray centre = CameraRays(c, 64, 48).ray(32, 24);
        EXPECT_NEAR(length(centre.direction), 1.0, 1e-15) << len;
        EXPECT_NEAR(centre.direction.x, std::sqrt(0.5), 1e-15) << len;
        EXPECT_NEAR(centre.direction.z, std::sqrt(0.5), 1e-15) << len;
        const Ray corner = CameraRays(c, 64, 48).ray(0, 0);
        EXPECT_TRUE(is_finite(corner.direction)) << len;
        EXPECT_GT(corner.direction.y, 0.0) << len;  // the top row looks up
    }
}

// CameraRays::rays4 is ray() four at a time in AVX's registers on processors that have it: the
// same bits, lane by lane, for points inside and far outside the image (directions whose length
// overflows and is rescaled), and for a camera that looks nowhere (look_at at its position: zero
// directions) or at NaN.
TEST(Render, CameraRaysFourAtATimeAreOneByOnes) {
    if (!cpu_has_avx())
        GTEST_SKIP() << "no AVX (or RAYCASTD_CPU=baseline): rays4 is ray() one by one here";
    const auto bits = [](double v) {
        std::uint64_t b;
        std::memcpy(&b, &v, sizeof b);
        return b;
    };
    const auto same = [&](const Vec3d& a, const Vec3d& b) {
        return bits(a.x) == bits(b.x) && bits(a.y) == bits(b.y) && bits(a.z) == bits(b.z);
    };
    std::vector<Camera> cameras;
    Camera c;
    c.position = {1.9, 2.2, -1.9};
    c.look_at = {0.13, 0.8, -0.04};
    c.up = {0, 1, 0};
    c.fov_y_deg = 40;
    cameras.push_back(c);
    c.fov_y_deg = 179.9;  // tan(fov/2) near 1e3
    cameras.push_back(c);
    c.look_at = c.position;
    cameras.push_back(c);
    c.look_at = {std::nan(""), 0, 0};
    cameras.push_back(c);
    std::uint64_t state = 7;
    const auto next = [&] {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return static_cast<double>(state >> 11) * 0x1p-53;
    };
    std::size_t rescaled = 0, compared = 0;
    for (std::size_t ci = 0; ci < cameras.size(); ++ci) {
        const CameraRays rays(cameras[ci], 1024, 768);
        for (int i = 0; i < 2000; ++i) {
            double x[4], y[4];
            for (int j = 0; j < 4; ++j) {
                // Mostly inside the image; every fifth point up to 5e299 pixels across and 5e149
                // down, where the direction's squared length overflows.
                const bool far = (i + j) % 5 == 0;
                x[j] = far ? (next() - 0.5) * 1e300 : next() * 1024;
                y[j] = far ? (next() - 0.5) * 1e150 : next() * 768;
            }
            Ray four[4];
            rays.rays4(four, x, y);
            for (int j = 0; j < 4; ++j) {
                const Ray one = rays.ray(x[j], y[j]);
                ++compared;
                // The first two cameras' far lanes: a direction whose squared length
                // overflowed, rescaled to a finite unit one.
                rescaled += ci < 2 && !(std::abs(x[j]) < 1e100) && is_finite(one.direction);
                ASSERT_TRUE(same(four[j].origin, one.origin)) << i << " " << j;
                ASSERT_TRUE(same(four[j].direction, one.direction))
                    << i << " " << j << " " << x[j] << " " << y[j];
                ASSERT_EQ(bits(four[j].tmin), bits(one.tmin));
                ASSERT_EQ(bits(four[j].tmax), bits(one.tmax));
            }
        }
    }
    EXPECT_EQ(compared, 4u * 2000u * 4u);
    EXPECT_GT(rescaled, 1000u);  // the lanes normalize() rescales were reached
}

TEST(Render, NoLightsTracesNoShadowRays) {
    auto engine = prepare(testing::tutorial_spheres());
    RenderOptions o = small();
    o.lighting = Lighting::scene;
    const RenderResult r = render(*engine, o).value();
    EXPECT_EQ(r.lighting, Lighting::scene);
    EXPECT_EQ(r.counts.primary, 40u * 30u);
    EXPECT_EQ(r.counts.shadow, 0u);
    EXPECT_EQ(r.counts.reflected + r.counts.refracted, 0u);
    // Ambient 1.0 only: a hit shows ka = 0.1 exactly.
    EXPECT_NEAR(r.image.at(20, 15).x, 0.1, 1e-7);
}

TEST(Render, AutoLightingGivesABareSceneTheHeadlight) {
    // The tutorial's spheres have no lights: auto takes the headlight. An odd size puts the
    // centre of pixel (20, 15) on the axis, the ray (0,0,1) that meets sphere 3 at (0,0,7.27)
    // with n = (0, −½, −√3/2); the headlight comes from l = (0,0,−1), so N·L = √3/2 and
    // I = ka·0.1 + 0.9·kd·√3/2 (+ 0.9·ks·(R·V)³², R·V = ½: ~4e−11).
    auto engine = prepare(testing::tutorial_spheres());
    RenderOptions o = small();
    o.width = 41;
    o.height = 31;
    const RenderResult r = render(*engine, o).value();
    EXPECT_EQ(r.lighting, Lighting::headlight);
    // Camera hits trace no shadow ray for the headlight, and the spheres are matte.
    EXPECT_EQ(r.counts.shadow, 0u);
    EXPECT_NEAR(r.image.at(20, 15).x, 0.1 * 0.1 + 0.9 * 0.7 * std::sqrt(3.0) / 2.0, 1e-6);
    // A point light makes auto the scene's lighting; an ambient light alone does not.
    EXPECT_EQ(render(*prepare(lit_spheres(0.0)), small()).value().lighting, Lighting::scene);
    Scene ambient_only = testing::tutorial_spheres();
    ambient_only.lights = {testing::ambient_light(0.5)};
    EXPECT_EQ(resolve_lighting(ambient_only, Lighting::automatic), Lighting::headlight);
    EXPECT_EQ(resolve_lighting(ambient_only, Lighting::scene), Lighting::scene);
}

TEST(Render, HeadlightReplacesTheSceneLightsAndShadowsOnlySecondaryHits) {
    // A lit matte scene with the headlight asked for: its point light is not used (no shadow
    // rays at all), and the picture differs from the scene-lit one.
    auto matte = prepare(lit_spheres(0.0));
    RenderOptions o = small();
    o.lighting = Lighting::headlight;
    const RenderResult head = render(*matte, o).value();
    EXPECT_EQ(head.lighting, Lighting::headlight);
    EXPECT_EQ(head.counts.shadow, 0u);
    EXPECT_NE(head.image.rgb, render(*matte, small()).value().image.rgb);
    // Reflecting spheres: every reflected ray that hits a sphere facing the headlight traces
    // one shadow ray, so 0 < shadow ≤ reflected.
    auto mirror = prepare(lit_spheres(0.5));
    const RenderResult r = render(*mirror, o).value();
    EXPECT_GT(r.counts.reflected, 0u);
    EXPECT_GT(r.counts.shadow, 0u);
    EXPECT_LE(r.counts.shadow, r.counts.reflected);
}

TEST(Render, LightingNames) {
    EXPECT_EQ(lighting_from_name("auto"), Lighting::automatic);
    EXPECT_EQ(lighting_from_name("headlight"), Lighting::headlight);
    EXPECT_EQ(lighting_from_name("scene"), Lighting::scene);
    EXPECT_FALSE(lighting_from_name("sun"));
    EXPECT_STREQ(to_string(Lighting::automatic), "auto");
}

TEST(Render, MatteSceneTracesNoSecondaryRays) {
    auto engine = prepare(lit_spheres(0.0));
    const RenderResult r = render(*engine, small()).value();
    EXPECT_GT(r.counts.shadow, 0u);
    EXPECT_EQ(r.counts.reflected, 0u);
    EXPECT_EQ(r.counts.refracted, 0u);
    auto mirror = prepare(lit_spheres(0.5));
    EXPECT_GT(render(*mirror, small()).value().counts.reflected, 0u);
}

TEST(Render, SamplesPerPixelMultiplyPrimaryRaysAndAreDeterministic) {
    auto engine = prepare(lit_spheres(0.3));
    RenderOptions o = small();
    o.spp = 5;
    const RenderResult a = render(*engine, o).value();
    const RenderResult b = render(*engine, o).value();
    EXPECT_EQ(a.counts.primary, 40u * 30u * 5u);
    EXPECT_EQ(a.image.rgb, b.image.rgb);
}

// Adaptive sampling (RenderOptions::adaptive): the first sample everywhere, the other spp − 1
// only where a pixel's first sample shows differently from a neighbour's. Such a pixel is the
// uniform render's exactly (the same samples, summed in the same order; exact precision, so the
// batches' different packets decide every ray the same); the others differ from it in 8 bits
// only where a feature falls between first samples. Fails when the second pass takes other
// samples than the uniform render (its pixels then match nothing), when it skips pixels at tile
// borders, or when the first pass' pixels keep a sum instead of an average.
TEST(Render, AdaptiveSamplingSupersamplesWhereNeighboursDiffer) {
    auto engine = prepare(lit_spheres(0.4));
    RenderOptions o = small();
    o.width = 80;
    o.height = 60;
    o.tile_size = 8;
    o.spp = 4;
    o.whitted.precision = Precision::exact;
    const RenderResult uniform = render(*engine, o).value();
    o.adaptive = true;
    const RenderResult adaptive = render(*engine, o).value();
    EXPECT_EQ(render(*engine, o).value().image.rgb, adaptive.image.rgb);  // deterministic
    const std::size_t pixels = 80 * 60;
    ASSERT_EQ((adaptive.counts.primary - pixels) % 3, 0u);
    const std::size_t more = (adaptive.counts.primary - pixels) / 3;
    EXPECT_GT(more, pixels / 20);  // the spheres' shading and silhouettes
    EXPECT_LT(more, pixels / 2);   // not the background
    std::size_t same = 0, shown_differently = 0;
    for (int y = 0; y < 60; ++y) {
        for (int x = 0; x < 80; ++x) {
            const Vec3d a = adaptive.image.at(x, y), u = uniform.image.at(x, y);
            same += a == u;
            for (int k = 0; k < 3; ++k)
                shown_differently +=
                    srgb_encode(static_cast<float>(a[k])) != srgb_encode(static_cast<float>(u[k]));
        }
    }
    EXPECT_GE(same, more);
    EXPECT_LE(shown_differently, pixels * 3 / 200);
    EXPECT_LT(adaptive.counts.shadow, uniform.counts.shadow);

    // Nothing in view: one sample a pixel.
    o.camera = Camera{{0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 30};
    EXPECT_EQ(render(*engine, o).value().counts.primary, pixels);
}

TEST(Render, DataModes) {
    auto engine = prepare(lit_spheres(0.0));
    const RenderResult ids = render(*engine, small(ShadingMode::object_id)).value();
    EXPECT_EQ(ids.image.at(0, 0), Vec3d{});  // a miss is black
    EXPECT_NE(ids.image.at(20, 15), Vec3d{});
    EXPECT_EQ(ids.counts.shadow, 0u);
    const RenderResult normals = render(*engine, small(ShadingMode::normal)).value();
    // The centre pixel sees sphere 3 at (0,0,7.27): normal (0,−½,−√3/2) → ((1+0)/2, ¼, …).
    EXPECT_NEAR(normals.image.at(20, 15).x, 0.5, 0.05);
    EXPECT_NEAR(normals.image.at(20, 15).y, 0.25, 0.05);
    const RenderResult depth = render(*engine, small(ShadingMode::depth)).value();
    EXPECT_GT(depth.image.at(20, 15).x, 0.0);
    EXPECT_LE(depth.image.at(20, 15).x, 1.0);
    const RenderResult bary = render(*engine, small(ShadingMode::barycentric)).value();
    EXPECT_EQ(bary.image.at(20, 15), Vec3d(1, 0, 0));  // spheres have u = v = 0
}

TEST(Render, ProgressCountsTiles) {
    auto engine = prepare(lit_spheres(0.0));
    RenderOptions o = small();
    o.tile_size = 8;
    RenderProgress progress;
    const auto r = render(*engine, o, &progress);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(progress.tiles_total.load(), tile_count(o));
    EXPECT_EQ(tile_count(o), 5u * 4u);
    EXPECT_EQ(progress.tiles_done.load(), progress.tiles_total.load());
    EXPECT_EQ(progress.samples_total.load(), 40u * 30u);
    EXPECT_EQ(progress.samples_done.load(), progress.samples_total.load());
}

// An adaptive render's progress is in camera samples: its total drops from every pixel's spp to
// what the second pass traces once the first pass has told which pixels need more, and it ends
// at what was traced. Its tiles count twice (two passes).
TEST(Render, AdaptiveProgressCountsSamples) {
    auto engine = prepare(lit_spheres(0.4));
    RenderOptions o = small();
    o.tile_size = 8;
    o.spp = 4;
    o.adaptive = true;
    RenderProgress progress;
    const auto r = render(*engine, o, &progress);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(progress.tiles_total.load(), 2 * tile_count(o));
    EXPECT_EQ(progress.tiles_done.load(), progress.tiles_total.load());
    EXPECT_EQ(progress.samples_total.load(), r.value().counts.primary);
    EXPECT_EQ(progress.samples_done.load(), r.value().counts.primary);
    EXPECT_LT(progress.samples_total.load(), 40u * 30u * 4u);
}

TEST(Render, CancelledTokenStopsBeforeTheNextTile) {
    auto engine = prepare(lit_spheres(0.0));
    RenderOptions o = small();
    o.tile_size = 8;
    o.cancel = CancelToken::make();
    o.cancel.cancel();
    RenderProgress stopped;
    const auto c = render(*engine, o, &stopped);
    ASSERT_FALSE(c.ok());
    EXPECT_EQ(c.status().code, Code::cancelled);
    EXPECT_EQ(stopped.tiles_done.load(), 0u);
}

TEST(Render, TokenFiredMidwayStopsTheRender) {
    // A poll callback that says stop once a few tiles are done (it is first asked
    // kPollInterval after the token is made): the render ends short of its tiles (each thread
    // finishes the tile it is on) and answers cancelled.
    auto engine = prepare(lit_spheres(0.3));
    RenderOptions o = small();
    o.width = o.height = 1024;
    o.tile_size = 8;
    RenderProgress progress;
    o.cancel = CancelToken::make(std::nullopt, [&] { return progress.tiles_done.load() >= 4; });
    const auto c = render(*engine, o, &progress);
    ASSERT_FALSE(c.ok());
    EXPECT_EQ(c.status().code, Code::cancelled);
    EXPECT_LT(progress.tiles_done.load(), tile_count(o));
}

TEST(Render, TokenThatNeverFiresChangesNothing) {
    // The same bytes with a default token, a token that could fire but does not, and one with
    // a deadline far away.
    auto engine = prepare(lit_spheres(0.3));
    RenderOptions o = small();
    const RenderResult plain = render(*engine, o).value();
    o.cancel =
        CancelToken::make(CancelToken::Clock::now() + std::chrono::hours(1), [] { return false; });
    const RenderResult armed = render(*engine, o).value();
    EXPECT_EQ(plain.image.rgb, armed.image.rgb);
    EXPECT_EQ(plain.counts.total(), armed.counts.total());
    EXPECT_FALSE(o.cancel.fired());
}

TEST(Render, SmallSceneScanAgreesWithExactBruteForce) {
    // Three spheres over a floor of two triangles: QueryEngine answers them by brute force
    // (exact); a render scans them itself (accel/scene_scan.h), exact's answers at refined,
    // fast's kernels at fast. Every pixel's colour through the scan (many_rays, as render()
    // asks) against the engine's own brute force (few_rays): the same bits at refined and
    // exact, within 1e-3 at fast.
    Scene s = lit_spheres(0.3);
    s.objects.push_back(testing::mesh_object(
        "floor", {{-40, -2.5, -5}, {-40, -2.5, 40}, {40, -2.5, -5}, {40, -2.5, 40}},
        {{0, 1, 2}, {2, 1, 3}}));
    auto engine = prepare(std::move(s));
    ASSERT_TRUE(engine->brute_force());
    const RenderOptions o = small();
    WhittedOptions brute_options = o.whitted;
    brute_options.precision = Precision::exact;
    brute_options.many_rays = false;
    const Whitted brute(*engine, brute_options);
    const CameraRays rays(*o.camera, o.width, o.height);
    for (Precision p : {Precision::fast, Precision::refined, Precision::exact}) {
        WhittedOptions scan_options = o.whitted;
        scan_options.precision = p;
        scan_options.many_rays = true;
        const Whitted scan(*engine, scan_options);
        int differ = 0, lit = 0;
        for (int y = 0; y < o.height; ++y) {
            for (int x = 0; x < o.width; ++x) {
                const Ray ray = rays.ray(x + 0.5, y + 0.5);
                RayCounts c1, c2;
                const Vec3d want = brute.radiance(ray, c1);
                const Vec3d got = scan.radiance(ray, c2);
                lit += want.x > 0.05;
                if (p == Precision::fast ? length(got - want) > 1e-3 : !(got == want))
                    ++differ;
                if (p != Precision::fast) {
                    EXPECT_EQ(c1.total(), c2.total());
                }
            }
        }
        EXPECT_EQ(differ, 0) << to_string(p);
        EXPECT_GT(lit, o.width * o.height / 10);
    }
    // The render says which path answered: exact for refined on a scene this small (API.md).
    RenderOptions r = o;
    r.whitted.precision = Precision::refined;
    EXPECT_EQ(render(*engine, r).value().precision, Precision::exact);
    r.whitted.precision = Precision::fast;
    EXPECT_EQ(render(*engine, r).value().precision, Precision::fast);
}

TEST(Render, RaysInBatchesGiveTheImageOfSingleRays) {
    // A mesh scene (a glass icosphere over a cube, both casting shadows, two lights, a mirror
    // sphere): rays traced generation by generation in batches (shadow rays in Embree
    // packets, reflected rays as closest-hit batches) against the same rays traced one by one.
    // At exact both decide every ray in double: the same picture. At fast and refined packets
    // and single rays are different float traversals, so a pixel may differ at a grazing
    // shadow edge: at most 0.5% of the channels by over 1e-3. The ray counts are the same.
    Scene s = lit_spheres(0.4);
    Material glass;
    glass.transparency = 0.7;
    glass.reflectivity = 0.2;
    glass.ior = 1.5;
    s.materials.push_back(glass);
    s.objects.push_back(testing::icosphere_object(2, {3.2, -1, 9}, 1.2));
    s.objects.back().material = static_cast<std::uint32_t>(s.materials.size() - 1);
    s.objects.push_back(testing::cube_object(-6, -2.5));
    s.lights.push_back(testing::point_light({-4, 6, 2}));
    auto engine = prepare(std::move(s));
    ASSERT_FALSE(engine->brute_force());
    for (Precision p : {Precision::exact, Precision::refined, Precision::fast}) {
        SCOPED_TRACE(to_string(p));
        RenderOptions o = small();
        o.width = 80;
        o.height = 60;
        o.whitted.precision = p;
        const RenderResult batched = render(*engine, o).value();
        o.whitted.trace_in_batches = false;
        const RenderResult single = render(*engine, o).value();
        EXPECT_EQ(batched.counts.shadow, single.counts.shadow);
        EXPECT_EQ(batched.counts.reflected, single.counts.reflected);
        EXPECT_GT(batched.counts.reflected, 100u);
        EXPECT_EQ(batched.counts.refracted, single.counts.refracted);
        EXPECT_GT(batched.counts.refracted, 100u);
        EXPECT_GT(batched.counts.shadow, 1000u);
        std::size_t differ = 0, bits_differ = 0;
        for (std::size_t i = 0; i < batched.image.rgb.size(); ++i) {
            if (std::abs(batched.image.rgb[i] - single.image.rgb[i]) > 1e-3f)
                ++differ;
            bits_differ += batched.image.rgb[i] != single.image.rgb[i];
        }
        if (p == Precision::exact) {
            // Bit for bit: shade_batch sums as shade_hit does (a float image can hide a last
            // bit of the double colour: Whitted.BatchesShadeAsOneHitAtATimeBitForBit compares
            // the doubles).
            EXPECT_EQ(bits_differ, 0u);
        } else {
            EXPECT_LE(differ, batched.image.rgb.size() / 200);
        }
    }
}

// A render frees the batch buffers its calling thread kept (engine/thread_scratch.h) when it
// returns, cancelled or not: a server thread that asked for one render does not hold them
// until it exits. In an arena of one thread the calling thread traces every tile, so that it
// leases (and, without the release, would keep) both kinds of buffer: the camera samples'
// and the shading batches'.
TEST(Render, ReturnsWithTheCallingThreadsBatchBuffersFreed) {
    Scene s = lit_spheres(0.4);
    s.objects.push_back(testing::icosphere_object(2, {3.2, -1, 9}, 1.2));
    s.objects.push_back(testing::cube_object(-6, -2.5));
    auto engine = prepare(std::move(s));
    ASSERT_FALSE(engine->brute_force());  // batches: a scanned scene traces ray by ray
    tbb::task_arena one_thread(1);
    for (bool cancelled : {false, true}) {
        SCOPED_TRACE(cancelled ? "cancelled" : "finished");
        RenderOptions o = small();
        o.spp = 2;
        RenderProgress progress;
        // What the calling thread kept between tiles, read by the token's poll, which the
        // render asks between tiles on this (its only) thread: the buffers the test is about.
        std::size_t kept_while_rendering = 0;
        o.width = o.height = 256;  // tens of ms on one thread; the poll starts after 10 ms
        o.tile_size = 8;
        o.cancel = CancelToken::make(std::nullopt, [&] {
            kept_while_rendering = std::max(kept_while_rendering, thread_scratch_bytes());
            // Cancelled: fired once a few tiles are done (as TokenFiredMidwayStopsTheRender).
            return cancelled && progress.tiles_done.load() >= 4;
        });
        std::optional<Result<RenderResult>> r;
        one_thread.execute([&] { r = render(*engine, o, &progress); });
        ASSERT_TRUE(r.has_value());
        EXPECT_EQ(r->ok(), !cancelled);
        EXPECT_GT(progress.tiles_done.load(), 0u);
        EXPECT_GT(kept_while_rendering, 0u);
        EXPECT_EQ(thread_scratch_bytes(), 0u);
    }
}

TEST(Render, ModeNames) {
    EXPECT_EQ(shading_mode_from_name("object_id"), ShadingMode::object_id);
    EXPECT_FALSE(shading_mode_from_name("toon"));
    EXPECT_STREQ(to_string(ShadingMode::barycentric), "barycentric");
}

}  // namespace
}  // namespace raycastd::engine
