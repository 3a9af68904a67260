// Shadow acne over whole views: a lit plane and a sphere, near the origin and 1e6 units away,
// rendered pixel by pixel through the Whitted tracer at every precision, with and without the
// tracer's own scan of small scenes. (It lives with the renderer because it looks through a
// camera: render/camera_rays.h.)

#include <array>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "engine/render/camera_rays.h"
#include "engine/shade/whitted.h"
#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

using testing::ambient_light;
using testing::sphere;

std::shared_ptr<const QueryEngine> prepare(Scene s) {
    auto built = QueryEngine::build(std::make_shared<const Scene>(std::move(s)));
    EXPECT_TRUE(built.ok()) << built.status().message;
    return *built;
}

struct AcneCase {
    Scene scene;
    Vec3d o;  ///< where the scene sits
    Vec3d light_dir;
};

AcneCase acne_scene(Vec3d o, int grid) {
    AcneCase c;
    c.o = o;
    c.light_dir = normalize(Vec3d{-0.3, -1.0, 0.2});
    Scene& s = c.scene;
    s.materials = {Material{}};
    s.materials[0].specular = {0, 0, 0};  // the lit plane has one exact value
    // The plane y = 0, 40 × 40, as grid × grid quads (shared edges everywhere).
    std::vector<Vec3d> p;
    std::vector<std::array<std::uint32_t, 3>> t;
    for (int j = 0; j <= grid; ++j) {
        for (int i = 0; i <= grid; ++i) {
            p.push_back(o + Vec3d{-20.0 + 40.0 * i / grid, 0.0, -20.0 + 40.0 * j / grid});
        }
    }
    const auto at = [&](int i, int j) { return static_cast<std::uint32_t>(j * (grid + 1) + i); };
    for (int j = 0; j < grid; ++j) {
        for (int i = 0; i < grid; ++i) {
            t.push_back({at(i, j), at(i, j + 1), at(i + 1, j)});  // counter-clockwise from +y
            t.push_back({at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)});
        }
    }
    s.objects.push_back(testing::mesh_object("plane", std::move(p), std::move(t)));
    s.objects.push_back(sphere("ball", o + Vec3d{0, 2.5, 0}, 1.5, 0));
    Light sun;
    sun.type = LightType::directional;
    sun.direction = c.light_dir;
    s.lights = {ambient_light(0.1), sun};
    Camera cam;
    cam.position = o + Vec3d{0, 7, -16};
    cam.look_at = o + Vec3d{0, 1, 0};
    s.camera = cam;
    return c;
}

/// Pixels that should be lit but are dark, over a 200 × 150 view.
int wrongly_dark_pixels(const AcneCase& c, Precision precision, bool scan, bool* used_bvh) {
    auto engine = prepare(c.scene);
    *used_bvh = !engine->brute_force();
    WhittedOptions opt;
    opt.precision = precision;
    opt.many_rays = scan;
    const Whitted w(*engine, opt);
    const CameraRays cam(*c.scene.camera, 200, 150);
    const Sphere& ball = c.scene.objects[1].sphere;
    const Vec3d l = -c.light_dir;
    const double ka_ia = 0.1 * 0.1, kd = 0.7;
    int dark = 0, checked = 0;
    for (int y = 0; y < 150; ++y) {
        for (int x = 0; x < 200; ++x) {
            const Ray ray = cam.ray(x + 0.5, y + 0.5);
            const auto hit = w.closest(ray);
            if (!hit)
                continue;
            const Vec3d p = ray.at(hit->t);
            RayCounts counts;
            const double got = w.shade_hit(ray, *hit, counts).x;
            double lit_value;
            if (hit->object == 0) {
                // Lit unless the line to the light passes within the ball (a margin either side
                // keeps the penumbra-free shadow edge out of the count).
                const Vec3d f = ball.center - p;
                const double along = dot(f, l);
                const double miss = length(f - l * along);
                if (along > 0 && miss < ball.radius * 1.01)
                    continue;
                lit_value = ka_ia + kd * l.y;
            } else {
                // A convex ball under a light from above: nothing can shadow its lit side.
                const double nl = dot(normalize(p - ball.center), l);
                if (nl < 0.05)
                    continue;
                lit_value = ka_ia + kd * nl;
            }
            ++checked;
            if (got < 0.5 * lit_value)
                ++dark;
        }
    }
    EXPECT_GT(checked, 10000);
    return dark;
}

TEST(Whitted, NoShadowAcneNearTheOriginOrFarFromIt) {
    for (const Vec3d o : {Vec3d{0, 0, 0}, Vec3d{1e6, 1e6, -1e6}}) {
        for (int grid : {1, 16}) {  // 2 triangles + a sphere: brute force; 512: Embree
            const AcneCase c = acne_scene(o, grid);
            for (Precision p : {Precision::fast, Precision::refined, Precision::exact}) {
                for (bool scan : {false, true}) {
                    bool bvh = false;
                    EXPECT_EQ(wrongly_dark_pixels(c, p, scan, &bvh), 0)
                        << "at " << o.x << ", grid " << grid << ", precision " << to_string(p)
                        << (scan ? ", scanned" : "");
                    EXPECT_EQ(bvh, grid > 1);
                }
            }
        }
    }
}

}  // namespace
}  // namespace raycastd::engine
