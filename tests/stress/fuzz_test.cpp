// Differential fuzzing (issue 6): random scenes and rays, the engine against the quad-precision
// reference, for a bounded time. Any disagreement beyond the documented bounds is saved as a case
// file under tests/stress/regressions/ (case_file.h), which the replay test runs on every build.
//
//   RAYCASTD_FUZZ_SECONDS  time budget (default 20; CI keeps the default, run longer by hand)
//   RAYCASTD_FUZZ_SEED     first seed (default 6); iteration i uses seed + i, so a run is
//                          reproducible up to where its time ran out
//   RAYCASTD_FUZZ_SAVE_DIR where to save disagreements (default: the regressions folder)
//
// Asserted for refined and exact: no wrong decision outside the bands, no leak, t within the
// hit's own t_err; for exact also t within 4 ulps of the reference.

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <gtest/gtest.h>

#include "engine/testing/scenes.h"
#include "tests/stress/case_file.h"
#include "tests/stress/generators.h"

namespace raycastd::stress {
namespace {

using engine::Object;
using engine::ObjectKind;
using engine::Ray;
using engine::Scene;
using engine::Vec3d;

constexpr double kExactMaxUlps = 4.0;

double env_or(const char* name, double fallback) {
    const char* v = std::getenv(name);
    return v && *v ? std::atof(v) : fallback;
}

/// Rays as a renderer spawns them (shade/spawn.h): from a point inside a triangle, moved off
/// its plane to the side the ray goes by a few float ulps of the scene (what a float tracer's
/// error adds to the offset), tmin 0. The float ray, started a margin before tmin, crosses the
/// ray's own triangle behind the origin: refined's hit filter must take that for neither a hit
/// nor a ray slipping past an edge (fat_triangles.h, outside_range_well_inside). Drawn from a
/// stream of their own into a case of their own (`c`'s scene), traced in a batch of their own,
/// so that every seed's other rays, the batches they are traced in, and the saved cases' seeds
/// stay as they were.
StressCase spawned_case(const StressCase& base, std::uint64_t seed) {
    StressCase c{base.suite + " spawned", base.scene, {}, base.closed};
    std::mt19937_64 rng(seed ^ 0x9E3779B97F4A7C15ull);
    std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);
    std::vector<const engine::TriangleMesh*> meshes;
    for (const Object& o : c.scene->objects) {
        if (o.kind == ObjectKind::mesh)
            meshes.push_back(o.mesh.get());
    }
    if (meshes.empty())
        return c;
    const engine::Bounds3 b = c.scene->bounds();
    for (int i = 0; i < 8; ++i) {
        const engine::TriangleMesh& m = *meshes[rng() % meshes.size()];
        const engine::Triangle t = m.triangle(rng() % m.size());
        const double s = u01(rng), w = u01(rng) * (1 - s);
        const Vec3d p = t.a + (t.b - t.a) * s + (t.c - t.a) * w;
        const Vec3d n = engine::triangle_normal(t);
        const Vec3d d = engine::normalize(Vec3d{u(rng), u(rng), u(rng)}) *
                        std::pow(10.0, -3.0 + 6.0 * u01(rng));
        if (!(engine::length(n) > 0) || !(engine::length(d) > 0))
            continue;
        // Float's unit roundoff times the float frame's magnitude (math/float_frame.h), 1 to 64
        // times over.
        const double frame = engine::length(p - b.center()) + 2.0 * engine::length(b.diagonal());
        const double offset = std::ldexp(frame, -24) * std::pow(2.0, 6.0 * u01(rng));
        Ray r{p + n * (engine::dot(n, d) >= 0 ? offset : -offset), d};
        r.tmin = 0.0;
        c.rays.push_back(r);
    }
    return c;
}

/// Bundles of eight rays that run together as a camera's neighbours do: one origin, directions
/// within ~0.01° of one another (ExactBvh::runs_with's cone is 0.8°), each aimed at a point near
/// one feature of the scene (a vertex, an edge, a silhouette), so that exact's batches walk them
/// as packets (ExactBvh::closest_packet) where random_case's rays each walk alone. Drawn from a
/// stream of their own into a case of their own, as spawned_case's, and each bundle starts at
/// a multiple of eight, where a batch's half-groups start.
StressCase bundled_case(const StressCase& base, std::uint64_t seed) {
    StressCase c{base.suite + " bundled", base.scene, {}, base.closed};
    std::mt19937_64 rng(seed ^ 0xD1B54A32D192ED03ull);
    std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);
    auto vec = [&] { return Vec3d{u(rng), u(rng), u(rng)}; };
    const engine::Bounds3 b = c.scene->bounds();
    const double size = engine::length(b.diagonal());
    if (c.scene->objects.empty() || !(size > 0.0) || !std::isfinite(size))
        return c;
    for (int bundle = 0; bundle < 4; ++bundle) {
        const Object& o = c.scene->objects[rng() % c.scene->objects.size()];
        Vec3d target;
        if (o.kind == ObjectKind::sphere) {
            target = o.sphere.center + engine::normalize(vec()) * o.sphere.radius;
        } else {
            const engine::TriangleMesh& m = *o.mesh;
            const engine::Triangle t = m.triangle(rng() % m.size());
            const double s = u01(rng);
            target = rng() % 2 ? t.a : t.a + (t.b - t.a) * s;  // a vertex or an edge point
        }
        const Vec3d origin = target + engine::normalize(vec()) * (size * (0.5 + 4.0 * u01(rng)));
        const double reach = engine::length(target - origin);
        for (int lane = 0; lane < 8; ++lane) {
            // The first lane at the feature itself, the others up to 1e-4 of the distance off it.
            const Vec3d aim =
                lane == 0 ? target
                          : target + vec() * (reach * std::pow(10.0, -12.0 + 8.0 * u01(rng)));
            Ray r{origin, (aim - origin) * std::pow(10.0, -2.0 + 4.0 * u01(rng))};
            if (rng() % 8 == 0)
                r.tmax = 0.5 + u01(rng);  // in units of the direction: short of some lanes' hits
            if (!(engine::length(r.direction) > 0))
                r.direction = target - origin;
            c.rays.push_back(r);
        }
    }
    return c;
}

/// A random scene at a random scale and offset, and rays aimed at its features (vertices, edge
/// points, sphere silhouettes, interiors) with random direction lengths.
StressCase random_case(std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1), u01(0, 1);
    auto vec = [&] { return Vec3d{u(rng), u(rng), u(rng)}; };
    auto pow10 = [&](double lo, double hi) { return std::pow(10.0, lo + (hi - lo) * u01(rng)); };
    const double scale = pow10(-6, 6);
    const Vec3d offset = rng() % 3 == 0 ? Vec3d{} : vec() * pow10(0, 7.5);
    StressCase c;
    c.suite = "fuzz " + std::to_string(seed);
    c.scene = std::make_shared<Scene>(empty_scene());
    const int spheres = static_cast<int>(rng() % 5), tris = static_cast<int>(rng() % 6);
    for (int k = 0; k < spheres; ++k) {
        c.scene->objects.push_back(sphere(offset + vec() * (3 * scale), scale * pow10(-3, 0.3)));
    }
    for (int k = 0; k < tris; ++k) {
        const Vec3d a = offset + vec() * (3 * scale);
        c.scene->objects.push_back(triangle(a, a + vec() * scale, a + vec() * scale));
    }
    if (rng() % 2 == 0 || c.scene->objects.empty()) {
        c.scene->objects.push_back(engine::testing::icosphere_object(
            static_cast<int>(rng() % 3), offset + vec() * scale, scale * pow10(-1, 0.3)));
    }
    c.closed.assign(c.scene->objects.size(), false);
    for (std::size_t i = 0; i < c.scene->objects.size(); ++i) {
        const Object& o = c.scene->objects[i];
        c.closed[i] = o.kind == ObjectKind::mesh && is_closed_mesh(*o.mesh);
    }
    for (int i = 0; i < 48; ++i) {
        const Object& o = c.scene->objects[rng() % c.scene->objects.size()];
        Vec3d target;
        if (o.kind == ObjectKind::sphere) {
            const double rho = rng() % 4 == 0 ? 1.0 + u(rng) * 1e-9 : std::sqrt(u01(rng));
            target = o.sphere.center + engine::normalize(vec()) * (o.sphere.radius * rho);
        } else {
            const engine::TriangleMesh& m = *o.mesh;
            const auto& t = m.triangles[rng() % m.size()];
            const double s = u01(rng), w = u01(rng) * (1 - s);
            switch (rng() % 3) {
                case 0:
                    target = m.positions[t[0]];
                    break;
                case 1:
                    target = m.positions[t[0]] + (m.positions[t[1]] - m.positions[t[0]]) * s;
                    break;
                default:
                    target = m.positions[t[0]] + (m.positions[t[1]] - m.positions[t[0]]) * s +
                             (m.positions[t[2]] - m.positions[t[0]]) * w;
            }
        }
        const Vec3d origin =
            rng() % 4 == 0 ? vec() * pow10(0, 7) : target + vec() * (scale * pow10(0, 3));
        Ray r{origin, (target - origin) * pow10(-6, 6)};
        if (!(engine::length(r.direction) > 0) ||
            !std::isfinite(engine::dot(r.direction, r.direction))) {
            continue;
        }
        if (rng() % 8 == 0)
            r.tmin = u01(rng) * 0.5;
        c.rays.push_back(r);
    }
    return c;
}

/// The engine's answers on `c` judged ray by ray: what breaks the asserted bounds, one line per
/// ray (empty when all is well), and those rays' indices.
std::string judge_case(const StressCase& c, std::vector<std::size_t>& bad_rays) {
    std::string wrong;
    const ReferenceAnswers refs = reference_answers(c);
    auto built = engine::QueryEngine::build(c.scene);
    if (!built.ok())
        return wrong;  // a scene the engine rejects is not a disagreement
    for (engine::Precision p : {engine::Precision::refined, engine::Precision::exact}) {
        engine::QueryOptions opt;
        opt.precision = p;
        const auto res = (*built)->intersect(c.rays, opt);
        const bool exact = res.precision == engine::Precision::exact;
        for (std::size_t i = 0; i < c.rays.size(); ++i) {
            StressCase one{c.suite, c.scene, {c.rays[i]}, c.closed};
            const ModeStats m = judge(one, {exact ? refs.exact[i] : refs.coarse[i]}, {res.hits[i]},
                                      exact ? "exact" : "refined", "");
            if (m.wrong() || m.leaks || m.t_err_violations ||
                (exact && m.max_ulps() > kExactMaxUlps)) {
                if (std::find(bad_rays.begin(), bad_rays.end(), i) == bad_rays.end())
                    bad_rays.push_back(i);  // once, whichever precision or mode found it
                wrong += std::string(engine::to_string(res.precision)) + " ray " +
                         std::to_string(i) + ": " + m.summary() + "\n";
            }
        }
        // `any` (a renderer's shadow rays): wherever the reference's hit or miss is robust.
        opt.mode = engine::Mode::any;
        const auto any = (*built)->intersect(c.rays, opt);
        for (std::size_t i = 0; i < c.rays.size(); ++i) {
            const RefAnswer& ref = exact ? refs.exact[i] : refs.coarse[i];
            if (ref.hit_robust && any.hits[i].valid() != ref.hit) {
                if (std::find(bad_rays.begin(), bad_rays.end(), i) == bad_rays.end())
                    bad_rays.push_back(i);
                wrong += std::string(engine::to_string(any.precision)) + " any, ray " +
                         std::to_string(i) + ": " + (ref.hit ? "missed\n" : "hit\n");
            }
        }
        if ((*built)->brute_force())
            break;
    }
    return wrong;
}

TEST(Fuzz, DifferentialAgainstReference) {
    const double budget = env_or("RAYCASTD_FUZZ_SECONDS", 20);
    const auto seed0 = static_cast<std::uint64_t>(env_or("RAYCASTD_FUZZ_SEED", 6));
    const char* save = std::getenv("RAYCASTD_FUZZ_SAVE_DIR");
    const std::filesystem::path dir =
        save && *save ? save : std::filesystem::path(RAYCASTD_STRESS_DIR) / "regressions";
    const auto start = std::chrono::steady_clock::now();
    std::size_t iterations = 0, rays = 0, failures = 0;
    for (std::uint64_t seed = seed0;; ++seed) {
        const double elapsed =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (elapsed > budget)
            break;
        // Each scene twice: as generated (brute force when small), and padded for Embree.
        StressCase base = random_case(seed);
        StressCase padded = base;
        padded.scene = std::make_shared<Scene>(*base.scene);
        pad_for_embree(*padded.scene, padded.closed);
        // Rays spawned off the surfaces, each scene's in a batch of its own (spawned_case), and
        // bundles of rays that run together (bundled_case), likewise.
        StressCase spawned = spawned_case(base, seed);
        StressCase spawned_padded = padded;
        spawned_padded.rays = spawned.rays;
        spawned_padded.suite = spawned.suite;
        StressCase bundled = bundled_case(base, seed);
        StressCase bundled_padded = padded;
        bundled_padded.rays = bundled.rays;
        bundled_padded.suite = bundled.suite;
        for (const StressCase* c :
             {&base, &padded, &spawned, &spawned_padded, &bundled, &bundled_padded}) {
            if (c->rays.empty())
                continue;
            ++iterations;
            rays += c->rays.size();
            std::vector<std::size_t> bad;
            const std::string wrong = judge_case(*c, bad);
            if (wrong.empty())
                continue;
            ++failures;
            // A bundle's rays are kept whole and in place: alone, a ray walks alone.
            const bool is_bundled = c == &bundled || c == &bundled_padded;
            StressCase keep = *c;
            if (!is_bundled) {
                keep.rays.clear();
                for (std::size_t i : bad)
                    keep.rays.push_back(c->rays[i]);
            }
            std::filesystem::create_directories(dir);
            const bool on_embree = c == &padded || c == &spawned_padded || c == &bundled_padded;
            const bool is_spawned = c == &spawned || c == &spawned_padded;
            const auto file =
                dir / ("fuzz-" + std::to_string(seed) + (on_embree ? "-embree" : "") +
                       (is_spawned ? "-spawned" : "") + (is_bundled ? "-bundled" : "") + ".txt");
            std::ofstream(file) << write_case(
                keep, "differential fuzz, seed " + std::to_string(seed) + "\n" + wrong);
            ADD_FAILURE() << "disagreement saved to " << file << "\n" << wrong;
        }
    }
    std::printf("[ fuzz     ] %zu scenes, %zu rays in %.0f s, %zu disagreements\n", iterations,
                rays, budget, failures);
    RecordProperty("scenes", static_cast<int>(iterations));
    RecordProperty("rays", static_cast<int>(rays));
    EXPECT_GT(iterations, 0u);
}

// Every saved case, replayed on both paths: once a disagreement is fixed it must stay fixed.
TEST(Fuzz, RegressionCases) {
    const std::filesystem::path dir = std::filesystem::path(RAYCASTD_STRESS_DIR) / "regressions";
    std::size_t files = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        if (entry.path().extension() != ".txt")
            continue;
        ++files;
        std::ifstream in(entry.path());
        std::stringstream text;
        text << in.rdbuf();
        StressCase c;
        std::string error;
        ASSERT_TRUE(read_case(text.str(), c, error)) << entry.path() << ": " << error;
        c.suite = entry.path().filename().string();
        StressCase padded = c;
        padded.scene = std::make_shared<Scene>(*c.scene);
        pad_for_embree(*padded.scene, padded.closed);
        std::vector<std::size_t> bad;
        EXPECT_EQ(judge_case(c, bad), "") << entry.path();
        EXPECT_EQ(judge_case(padded, bad), "") << entry.path() << " (padded for Embree)";
        // Each ray again as the first lane of an incoherent packet (the other 15: its direction
        // with the signs and order of its components changed): Embree's packet kernels and the
        // per-lane contexts of refined's hit filter, not only rtcIntersect1.
        StressCase packed = padded;
        packed.rays.clear();
        for (const engine::Ray& r : c.rays) {
            const engine::Vec3d d = r.direction;
            for (int k = 0; k < 16; ++k) {
                engine::Ray lane = r;
                const engine::Vec3d e = k < 8 ? d : engine::Vec3d{d.y, d.z, d.x};
                lane.direction = {(k & 1) ? -e.x : e.x, (k & 2) ? -e.y : e.y, (k & 4) ? -e.z : e.z};
                packed.rays.push_back(lane);
            }
        }
        EXPECT_EQ(judge_case(packed, bad), "") << entry.path() << " (in incoherent packets)";
    }
    EXPECT_GT(files, 0u) << "no cases in " << dir;
}

}  // namespace
}  // namespace raycastd::stress
