#include "bench/workloads.h"

#include <cmath>
#include <cstring>
#include <map>
#include <utility>

#include <gtest/gtest.h>

namespace raycastd::bench {
namespace {

using Edge = std::pair<std::uint32_t, std::uint32_t>;

TEST(Icosphere, HasTheAdvertisedSize) {
    for (int level = 0; level <= 4; ++level) {
        const Workload w = make_icosphere(level);
        const std::size_t quads = std::size_t{1} << (2 * level);  // 4^level
        EXPECT_EQ(w.triangles.size(), 20 * quads);
        EXPECT_EQ(w.positions.size(),
                  10 * quads + 2);  // Euler: V = E − F + 2 = 30·4^L − 20·4^L + 2
    }
    EXPECT_EQ(make_icosphere(6).triangles.size(), 81920u);
}

// Closed and consistently oriented: every directed edge appears once and its reverse once, so
// every edge is shared by exactly two triangles that traverse it in opposite directions.
TEST(Icosphere, IsClosedAndConsistentlyOriented) {
    const Workload w = make_icosphere(3);
    std::map<Edge, int> directed;
    for (const auto& t : w.triangles) {
        for (int k = 0; k < 3; ++k)
            ++directed[{t[k], t[(k + 1) % 3]}];
    }
    for (const auto& [edge, count] : directed) {
        EXPECT_EQ(count, 1);
        EXPECT_EQ(directed.count({edge.second, edge.first}), 1u);
    }
}

TEST(Icosphere, VerticesOnTheUnitSphereAndFacesOutward) {
    const Workload w = make_icosphere(3);
    for (const auto& p : w.positions) {
        EXPECT_NEAR(std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]), 1.0, 1e-6);
    }
    for (const auto& t : w.triangles) {
        const auto& a = w.positions[t[0]];
        const auto& b = w.positions[t[1]];
        const auto& c = w.positions[t[2]];
        const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                             e1[0] * e2[1] - e1[1] * e2[0]};
        EXPECT_GT(
            n[0] * (a[0] + b[0] + c[0]) + n[1] * (a[1] + b[1] + c[1]) + n[2] * (a[2] + b[2] + c[2]),
            0.0);
    }
}

TEST(IcosphereField, MergesCopiesWithIndicesInRange) {
    const Workload w = make_icosphere_field(10, 2, 7);
    EXPECT_EQ(w.triangles.size(), 10u * 320u);
    for (const auto& t : w.triangles) {
        for (auto i : t)
            EXPECT_LT(i, w.positions.size());
    }
}

TEST(SphereField, IsReproducible) {
    const Workload a = make_sphere_field(50, 3);
    const Workload b = make_sphere_field(50, 3);
    ASSERT_EQ(a.spheres.size(), 50u);
    EXPECT_EQ(a.spheres, b.spheres);
    EXPECT_NE(a.spheres, make_sphere_field(50, 4).spheres);
    for (const auto& s : a.spheres)
        EXPECT_GT(s[3], 0.0f);
}

TEST(CameraRays, ComeInFourByFourTilesAndFrameTheObject) {
    const Workload w = make_icosphere(2);
    const auto rays = camera_rays(w, 8, 8);
    ASSERT_EQ(rays.size(), 64u);
    // The first 16 rays are the top-left 4×4 tile: they point left (−x) and up (+y).
    for (int i = 0; i < 16; ++i) {
        EXPECT_LT(rays[i].dx, 0.0f);
        EXPECT_GT(rays[i].dy, 0.0f);
    }
    // Ray 16 starts the second tile, to the right.
    EXPECT_GT(rays[16].dx, 0.0f);
    for (const auto& r : rays) {
        EXPECT_NEAR(r.dx * r.dx + r.dy * r.dy + r.dz * r.dz, 1.0f, 1e-6f);
        EXPECT_EQ(r.tmin, 0.0f);
        EXPECT_EQ(r.tmax, kRayTmax);
    }
    // The unit sphere just fills the image height: the eye is 1 / sin(22.5°) from its centre.
    EXPECT_NEAR(-rays[0].oz, 1.0 / std::sin(22.5 * 3.14159265358979323846 / 180.0), 1e-5);
}

TEST(RandomRays, StayInTheScaledBoundsAndAreReproducible) {
    const Workload w = make_icosphere(1);
    const auto rays = random_rays(w, 1000, 11);
    EXPECT_EQ(rays.size(), 1000u);
    for (const auto& r : rays) {
        for (float o : {r.ox, r.oy, r.oz}) {
            EXPECT_LE(std::abs(o), 1.5f);
        }
        EXPECT_NEAR(r.dx * r.dx + r.dy * r.dy + r.dz * r.dz, 1.0f, 1e-5f);
    }
    const auto again = random_rays(w, 1000, 11);
    EXPECT_EQ(rays[999].dz, again[999].dz);
}

TEST(EngineScene, CarriesTheSameGeometry) {
    const Workload mesh = make_icosphere(1);
    const engine::Scene s = to_engine_scene(mesh);
    ASSERT_EQ(s.objects.size(), 1u);
    EXPECT_EQ(s.triangle_count(), mesh.triangles.size());
    EXPECT_EQ(s.objects[0].mesh->positions[5].x, double{mesh.positions[5][0]});
    EXPECT_TRUE(engine::validate(s).ok());

    const Workload spheres = make_sphere_field(5, 1);
    const engine::Scene t = to_engine_scene(spheres);
    EXPECT_EQ(t.sphere_count(), 5u);
    EXPECT_EQ(t.objects[4].sphere.radius, double{spheres.spheres[4][3]});
}

// The presets' workloads and ray sets, as bench_intersect and bench_probe make them: the sizes
// each preset gives, and the seeds that make every program's B, C and random rays the same ones.
TEST(Presets, MakeTheirWorkloadsAndRaySets) {
    const WorkloadSizes& s = kSmokeSizes;
    const Workload a = make_workload('A', s);
    EXPECT_EQ(a.triangles.size(), 20u * 16u);  // 20·4^2
    const Workload b = make_workload('B', s);
    EXPECT_EQ(b.triangles.size(), 8u * 80u);  // 8 icospheres of level 1
    EXPECT_EQ(b.positions, make_icosphere_field(8, 1, kFieldSeed).positions);
    const Workload c = make_workload('C', s);
    ASSERT_EQ(c.spheres.size(), 20u);
    EXPECT_EQ(c.spheres, make_sphere_field(20, kSphereSeed).spheres);
    EXPECT_EQ(ray_set(a, /*coherent=*/true, s).size(), 64u * 64u);
    const std::vector<RayRecord> random = ray_set(b, /*coherent=*/false, s);
    ASSERT_EQ(random.size(), 4096u);
    const std::vector<RayRecord> again = random_rays(b, 4096, kRaySeed);
    EXPECT_EQ(std::memcmp(random.data(), again.data(), random.size() * sizeof(RayRecord)), 0);
    EXPECT_EQ(make_workload('A', kQuickSizes).triangles.size(), 20u * 256u);  // 20·4^4
    EXPECT_EQ(kFullSizes.random_rays, std::size_t{1} << 20);
}

}  // namespace
}  // namespace raycastd::bench
