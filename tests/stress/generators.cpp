#include "tests/stress/generators.h"

#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include "engine/load/model_loader.h"
#include "engine/math/float_bounds.h"
#include "engine/testing/scenes.h"

namespace raycastd::stress {

using engine::Object;
using engine::ObjectKind;
using engine::Ray;
using engine::Scene;
using engine::Vec3d;

namespace {

using Rng = std::mt19937_64;

double uniform(Rng& rng, double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
}
int uniform_int(Rng& rng, int lo, int hi) {
    return std::uniform_int_distribution<int>(lo, hi)(rng);
}
double log_uniform(Rng& rng, double lo, double hi) {
    return std::exp(uniform(rng, std::log(lo), std::log(hi)));
}
Vec3d unit(Rng& rng) {
    for (;;) {
        const Vec3d v{uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)};
        const double l = engine::length(v);
        if (l > 0.1 && l <= 1.0)
            return v / l;
    }
}
/// A unit vector perpendicular to n.
Vec3d perpendicular(Rng& rng, const Vec3d& n) {
    for (;;) {
        const Vec3d v = engine::cross(n, unit(rng));
        const double l = engine::length(v);
        if (l > 0.1)
            return v / l;
    }
}
Ray ray_to(const Vec3d& origin, const Vec3d& target) {
    return Ray{origin, target - origin};
}

/// The case as given, and (when it is small enough for the brute-force path) its padded twin
/// for the Embree path.
std::vector<StressCase> both_paths(const std::string& suite, Scene scene, std::vector<Ray> rays,
                                   std::vector<bool> closed = {}) {
    closed.resize(scene.objects.size(), false);
    std::vector<StressCase> out;
    if (primitive_count(scene) <= 16) {
        out.push_back({suite, std::make_shared<Scene>(scene), rays, closed});
        pad_for_embree(scene, closed);
    }
    out.push_back({suite + "/embree", std::make_shared<Scene>(std::move(scene)), std::move(rays),
                   std::move(closed)});
    return out;
}

std::vector<StressCase> embree_only(const std::string& suite, Scene scene, std::vector<Ray> rays,
                                    std::vector<bool> closed) {
    closed.resize(scene.objects.size(), false);
    if (primitive_count(scene) <= 16)
        pad_for_embree(scene, closed);
    return {{suite + "/embree", std::make_shared<Scene>(std::move(scene)), std::move(rays),
             std::move(closed)}};
}

/// Rays into a closed mesh aimed exactly at its vertices, at rounded points of its edges and at
/// its edge midpoints, from outside along the outward direction `outward(p)` jittered by up to
/// half its length sideways (so that the ray enters the solid there).
template <class Outward>
std::vector<Ray> edge_and_vertex_rays(Rng& rng, const engine::TriangleMesh& m, int n,
                                      double distance, Outward&& outward) {
    std::vector<Ray> rays;
    for (int i = 0; i < n; ++i) {
        const auto& t = m.triangles[static_cast<std::size_t>(
            uniform_int(rng, 0, static_cast<int>(m.size()) - 1))];
        const int k = uniform_int(rng, 0, 2);
        const Vec3d p = m.positions[t[static_cast<std::size_t>(k)]];
        const Vec3d q = m.positions[t[static_cast<std::size_t>((k + 1) % 3)]];
        Vec3d target;
        switch (i % 3) {
            case 0:
                target = p;
                break;
            case 1:
                target = p + (q - p) * uniform(rng, 0, 1);
                break;
            default:
                target = (p + q) * 0.5;
                break;
        }
        const Vec3d n_out = outward(target);
        const Vec3d side = perpendicular(rng, n_out) * uniform(rng, 0, 0.5);
        rays.push_back(ray_to(target + (n_out + side) * (distance * uniform(rng, 0.5, 2)), target));
    }
    return rays;
}

}  // namespace

Scene empty_scene() {
    Scene s;
    s.materials.push_back(engine::Material{});
    s.material_names.push_back("default");
    return s;
}

Object sphere(Vec3d center, double radius, std::string name) {
    Object o;
    o.kind = ObjectKind::sphere;
    o.name = std::move(name);
    o.sphere = {center, radius};
    return o;
}

Object triangle(Vec3d a, Vec3d b, Vec3d c, std::string name) {
    return engine::testing::mesh_object(std::move(name), {a, b, c}, {{0, 1, 2}});
}

std::vector<StressCase> far_spheres(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 1);
    Scene s = empty_scene();
    for (int k = 3; k <= 9; ++k)
        s.objects.push_back(sphere(unit(rng) * std::pow(10.0, k), 1.0));
    std::vector<Ray> rays;
    for (int i = 0; i < g.rays; ++i) {
        const Object& o = s.objects[static_cast<std::size_t>(i) % s.objects.size()];
        const Vec3d origin{uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)};
        const Vec3d axis = engine::normalize(o.sphere.center - origin);
        // Inside the silhouette disc mostly, just outside it for one ray in eight.
        const double rho = i % 8 == 0 ? uniform(rng, 1.0001, 1.01) : std::sqrt(uniform(rng, 0, 1));
        const Vec3d target = o.sphere.center + perpendicular(rng, axis) * (rho * o.sphere.radius);
        rays.push_back(ray_to(origin, target));
    }
    return both_paths("far spheres", std::move(s), std::move(rays));
}

std::vector<StressCase> tiny_spheres(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 2);
    Scene s = empty_scene();
    const double radii[] = {1e-6, 1e-6, 1e-5, 1e-4, 1e-3, 1e-6, 1e-5, 1e-6};
    const double dists[] = {1e3, 1e2, 1e3, 1e3, 1e3, 1.0, 10.0, 5e2};
    for (int k = 0; k < 8; ++k)
        s.objects.push_back(sphere(unit(rng) * dists[k], radii[k]));
    std::vector<Ray> rays;
    for (int i = 0; i < g.rays; ++i) {
        const Object& o = s.objects[static_cast<std::size_t>(i) % s.objects.size()];
        const Vec3d axis = engine::normalize(o.sphere.center);
        const double rho = i % 8 == 0 ? uniform(rng, 1.0001, 1.01) : std::sqrt(uniform(rng, 0, 1));
        const Vec3d target = o.sphere.center + perpendicular(rng, axis) * (rho * o.sphere.radius);
        rays.push_back(ray_to(Vec3d{0, 0, 0}, target));
    }
    return both_paths("tiny spheres", std::move(s), std::move(rays));
}

std::vector<StressCase> tangent_rays(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 3);
    Scene s = empty_scene();
    for (int k = 0; k < 6; ++k) {
        s.objects.push_back(
            sphere(Vec3d{uniform(rng, -10, 10), uniform(rng, -10, 10), uniform(rng, -10, 10)},
                   uniform(rng, 0.5, 2)));
    }
    // Exactly tangent by construction: representable points at distance exactly r.
    s.objects.push_back(sphere({0, 0, 40}, 5));  // tangent to lines through (3, 4, 40) ⟂ (3, 4, 0)
    s.objects.push_back(sphere({20, 0, 0}, 1));  // tangent to lines through (21, 0, z) along y
    std::vector<Ray> rays;
    const double deltas[] = {1e-12, -1e-12, 1e-10, -1e-10, 1e-8, -1e-8, 1e-6, -1e-6, 1e-4, -1e-4};
    for (int i = 0; i < g.rays; ++i) {
        if (i % 16 == 0) {
            const double z = uniform(rng, 35, 45);
            const double sgn = i % 32 == 0 ? 1.0 : -1.0;
            rays.push_back(Ray{{3 - 4 * 8 * sgn, 4 + 3 * 8 * sgn, z}, {4 * sgn, -3 * sgn, 0}});
            continue;
        }
        if (i % 16 == 1) {
            rays.push_back(Ray{{21, -7, uniform(rng, -1, 1)}, {0, 1, 0}});
            continue;
        }
        const Object& o = s.objects[static_cast<std::size_t>(i) % 6];
        const double delta = deltas[static_cast<std::size_t>(i) % 10];
        const Vec3d w = unit(rng);
        const Vec3d d = perpendicular(rng, w);
        const Vec3d p = o.sphere.center + w * (o.sphere.radius * (1 + delta));
        rays.push_back(Ray{p - d * uniform(rng, 5, 20), d * log_uniform(rng, 0.1, 10)});
    }
    return both_paths("tangent rays", std::move(s), std::move(rays));
}

std::vector<StressCase> mesh_edges(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 4);
    std::vector<StressCase> out;
    {
        Scene s = empty_scene();
        s.objects.push_back(engine::testing::cube_object(-1, 1));
        const Vec3d c{0, 0, 0};
        auto rays = edge_and_vertex_rays(rng, *s.objects[0].mesh, g.rays, 3.0,
                                         [&](const Vec3d& p) { return engine::normalize(p - c); });
        for (auto& cs : both_paths("mesh edges", std::move(s), std::move(rays), {true})) {
            out.push_back(std::move(cs));
        }
    }
    for (int level = 0; level <= g.max_icosphere_level; ++level) {
        Scene s = empty_scene();
        const Vec3d c{uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)};
        s.objects.push_back(engine::testing::icosphere_object(level, c, 1.0));
        const int n = level >= 5 ? g.rays / 2 : g.rays;
        auto rays = edge_and_vertex_rays(rng, *s.objects[0].mesh, n, 3.0,
                                         [&](const Vec3d& p) { return engine::normalize(p - c); });
        for (auto& cs : both_paths("mesh edges", std::move(s), std::move(rays), {true})) {
            out.push_back(std::move(cs));
        }
    }
    return out;
}

std::vector<StressCase> closed_models(const GenOptions& g, const std::string& shared_dir) {
    Rng rng(g.seed * 1000 + 5);
    const char* files[] = {"spot/spot.obj",       "fandisk/fandisk.obj", "cube_off/Cube.off",
                           "suzanne/suzanne.obj", "cow/cow.obj",         "bunny_ply/bunny.ply",
                           "ballA_off/ballA.off", "beetle/beetle.obj"};
    std::vector<StressCase> out;
    for (const char* f : files) {
        const std::string path = shared_dir + "/data/models/" + f;
        std::ifstream in(path, std::ios::binary);
        if (!in)
            continue;
        std::stringstream bytes;
        bytes << in.rdbuf();
        auto fmt = engine::format_from_name(path);
        if (!fmt)
            continue;
        auto model = engine::load_model(bytes.str(), *fmt, engine::no_resources(), f);
        if (!model.ok() || model->parts.size() != 1)
            continue;
        engine::TriangleMesh mesh = model->parts[0].mesh;
        if (!is_closed_mesh(mesh) || mesh.size() > 40000)
            continue;
        // Outward vertex directions: the area-weighted normals of the incident triangles.
        std::vector<Vec3d> vn(mesh.positions.size());
        for (std::size_t t = 0; t < mesh.size(); ++t) {
            const engine::Triangle tri = mesh.triangle(t);
            const Vec3d n = engine::cross(tri.b - tri.a, tri.c - tri.a);
            for (auto idx : mesh.triangles[t])
                vn[idx] += n;
        }
        const engine::Bounds3 b = mesh.bounds();
        const double size = engine::length(b.diagonal());
        // Edge points take the normal of the edge's first vertex: near enough to enter there.
        auto outward = [&](const Vec3d& p) {
            std::size_t best = 0;
            double bd = 1e300;
            for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
                const Vec3d e = mesh.positions[i] - p;
                const double d2 = engine::dot(e, e);
                if (d2 < bd) {
                    bd = d2;
                    best = i;
                }
            }
            return engine::normalize(vn[best]);
        };
        Scene s = empty_scene();
        Object o;
        o.kind = ObjectKind::mesh;
        o.name = f;
        o.mesh = std::make_shared<engine::TriangleMesh>(mesh);
        s.objects.push_back(o);
        const int n =
            std::max(1, static_cast<int>(g.rays * 2000 / std::max<std::size_t>(2000, mesh.size())));
        auto rays = edge_and_vertex_rays(rng, mesh, n, 0.3 * size, outward);
        for (auto& cs : embree_only(std::string("closed models (") + f + ")", std::move(s),
                                    std::move(rays), {true})) {
            out.push_back(std::move(cs));
        }
    }
    return out;
}

std::vector<StressCase> slivers(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 6);
    Scene s = empty_scene();
    for (int k = 0; k < 12; ++k) {
        const Vec3d a{uniform(rng, -3, 3), uniform(rng, -3, 3), uniform(rng, -3, 3)};
        const Vec3d e1 = unit(rng), e2 = perpendicular(rng, e1);
        const double len = uniform(rng, 0.5, 3);
        const double angle = log_uniform(rng, 1e-9, 1e-6);
        const Vec3d b = a + e1 * len;
        // Alternate needles (a tiny angle at a) and caps (a third vertex almost on edge ab).
        const Vec3d c = k % 2 == 0 ? a + (e1 * std::cos(angle) + e2 * std::sin(angle)) *
                                             (len * uniform(rng, 0.5, 1))
                                   : a + e1 * (len * uniform(rng, 0.2, 0.8)) + e2 * (len * angle);
        s.objects.push_back(triangle(a, b, c, "sliver " + std::to_string(k)));
    }
    std::vector<Ray> rays;
    for (int i = 0; i < g.rays; ++i) {
        const engine::Triangle t =
            s.objects[static_cast<std::size_t>(i) % s.objects.size()].mesh->triangle(0);
        double u = uniform(rng, 0, 1), v = uniform(rng, 0, 1);
        if (u + v > 1) {
            u = 1 - u;
            v = 1 - v;
        }
        if (i % 4 == 3)
            v = 0;  // on edge ab (rounded)
        const Vec3d target = t.a + (t.b - t.a) * u + (t.c - t.a) * v;
        rays.push_back(ray_to(target + unit(rng) * uniform(rng, 2, 8), target));
    }
    return both_paths("slivers", std::move(s), std::move(rays));
}

std::vector<StressCase> huge_coordinates(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 7);
    const Vec3d offset{1e7, -1e7, 1e7};
    std::vector<StressCase> out;
    // 0: spheres and triangles (both paths); 1: plus a closed icosphere; 2: triangles only (the
    // case Open3D can take too).
    for (int variant = 0; variant < 3; ++variant) {
        Scene s = empty_scene();
        std::vector<bool> closed;
        for (int k = 0; k < (variant == 2 ? 0 : 4); ++k) {
            s.objects.push_back(
                sphere(offset + unit(rng) * uniform(rng, 2, 6), uniform(rng, 0.3, 1)));
            closed.push_back(false);
        }
        for (int k = 0; k < 3; ++k) {
            const Vec3d a = offset + unit(rng) * uniform(rng, 2, 6);
            s.objects.push_back(triangle(a, a + unit(rng), a + unit(rng)));
            closed.push_back(false);
        }
        if (variant >= 1) {
            s.objects.push_back(engine::testing::icosphere_object(3, offset, 1.5));
            closed.push_back(true);
        }
        std::vector<Ray> rays;
        for (int i = 0; i < g.rays; ++i) {
            const Object& o = s.objects[static_cast<std::size_t>(i) % s.objects.size()];
            Vec3d target;
            if (o.kind == ObjectKind::sphere) {
                target = o.sphere.center + unit(rng) * (0.9 * o.sphere.radius);
            } else {
                const engine::Triangle t = o.mesh->triangle(static_cast<std::size_t>(
                    uniform_int(rng, 0, static_cast<int>(o.mesh->size()) - 1)));
                const double u = uniform(rng, 0, 0.5), v = uniform(rng, 0, 0.5);
                target = i % 5 == 0 ? t.a : t.a + (t.b - t.a) * u + (t.c - t.a) * v;
            }
            // Local rays (origin near the objects) and rays from the world origin.
            const Vec3d origin = i % 2 == 0 ? offset + unit(rng) * uniform(rng, 8, 20)
                                            : unit(rng) * uniform(rng, 0, 1);
            rays.push_back(ray_to(origin, target));
        }
        auto cases = variant == 0 ? both_paths("huge coordinates", std::move(s), std::move(rays),
                                               std::move(closed))
                                  : embree_only(variant == 1 ? "huge coordinates (mesh)"
                                                             : "huge coordinates (triangles)",
                                                std::move(s), std::move(rays), std::move(closed));
        for (auto& cs : cases)
            out.push_back(std::move(cs));
    }
    return out;
}

std::vector<StressCase> nearly_parallel(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 8);
    Scene s = empty_scene();
    for (int k = 0; k < 8; ++k) {
        const Vec3d a{uniform(rng, -3, 3), uniform(rng, -3, 3), uniform(rng, -3, 3)};
        s.objects.push_back(triangle(a, a + unit(rng) * 2.0, a + unit(rng) * 2.0));
    }
    std::vector<Ray> rays;
    for (int i = 0; i < g.rays; ++i) {
        const engine::Triangle t =
            s.objects[static_cast<std::size_t>(i) % s.objects.size()].mesh->triangle(0);
        const Vec3d n = engine::triangle_normal(t);
        const double u = uniform(rng, 0.05, 0.45), v = uniform(rng, 0.05, 0.45);
        const Vec3d target = t.a + (t.b - t.a) * u + (t.c - t.a) * v;
        const double angle = std::pow(10.0, -uniform_int(rng, 2, 9)) * (i % 2 ? 1 : -1);
        const Vec3d d = perpendicular(rng, n) * std::cos(angle) + n * std::sin(angle);
        rays.push_back(Ray{target - d * uniform(rng, 0.5, 2), d});
    }
    return both_paths("nearly parallel", std::move(s), std::move(rays));
}

std::vector<StressCase> origin_on_surface(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 9);
    Scene s = empty_scene();
    // Dyadic centres and radii: the poles c ± r·e_k are exact doubles.
    s.objects.push_back(sphere({0.5, 0.25, 8}, 2));
    s.objects.push_back(sphere({-3, 1, 6}, 0.75));
    // Axis-aligned triangles: every dyadic point of their plane inside them is exact.
    s.objects.push_back(triangle({-4, -4, 3}, {4, -4, 3}, {-4, 4, 3}));
    s.objects.push_back(triangle({2, -4, -4}, {2, 4, -4}, {2, -4, 4}));
    s.objects.push_back(triangle({-1.3, 0.7, 12.1}, {3.1, 2.9, 11.7}, {0.3, -2.2, 13.3}));
    std::vector<Ray> rays;
    for (int i = 0; i < g.rays; ++i) {
        Vec3d origin;
        const int which = i % 5;
        if (which < 2) {
            const auto& sp = s.objects[static_cast<std::size_t>(which)].sphere;
            Vec3d e{0, 0, 0};
            const int axis = uniform_int(rng, 0, 2);
            e[static_cast<std::size_t>(axis)] = uniform_int(rng, 0, 1) ? 1.0 : -1.0;
            origin = sp.center + e * sp.radius;
        } else if (which == 2) {
            origin = {std::ldexp(uniform_int(rng, -60, 60), -4),
                      std::ldexp(uniform_int(rng, -60, 0), -4), 3};
        } else if (which == 3) {
            origin = {2, std::ldexp(uniform_int(rng, -60, 0), -4),
                      std::ldexp(uniform_int(rng, -60, 0), -4)};
        } else {
            const engine::Triangle t = s.objects[4].mesh->triangle(0);
            const Vec3d vs[3] = {t.a, t.b, t.c};
            origin = vs[uniform_int(rng, 0, 2)];
        }
        Ray r{origin, unit(rng) * log_uniform(rng, 0.1, 10)};
        // Half the rays leave the surface with a small tmin, as a spawned ray would.
        if (i % 2 == 1)
            r.tmin = 1e-6 / engine::length(r.direction);
        rays.push_back(r);
    }
    return both_paths("origin on surface", std::move(s), std::move(rays));
}

std::vector<StressCase> direction_lengths(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 10);
    Scene s = empty_scene();
    std::vector<bool> closed;
    for (int k = 0; k < 5; ++k) {
        s.objects.push_back(sphere({uniform(rng, -5, 5), uniform(rng, -5, 5), uniform(rng, -5, 5)},
                                   uniform(rng, 0.2, 1.5)));
        closed.push_back(false);
    }
    for (int k = 0; k < 5; ++k) {
        const Vec3d a{uniform(rng, -5, 5), uniform(rng, -5, 5), uniform(rng, -5, 5)};
        s.objects.push_back(triangle(a, a + unit(rng) * 2.0, a + unit(rng) * 2.0));
        closed.push_back(false);
    }
    Scene big = s;
    std::vector<bool> big_closed = closed;
    big.objects.push_back(engine::testing::icosphere_object(2, {0, 0, 0}, 1.2));
    big_closed.push_back(true);
    auto make_rays = [&](const Scene& sc) {
        std::vector<Ray> rays;
        for (int i = 0; i < g.rays; ++i) {
            const Object& o = sc.objects[static_cast<std::size_t>(i) % sc.objects.size()];
            Vec3d target = o.kind == ObjectKind::sphere
                               ? o.sphere.center + unit(rng) * (0.8 * o.sphere.radius)
                               : o.mesh->triangle(0).a * 0.5 + o.mesh->triangle(0).b * 0.25 +
                                     o.mesh->triangle(0).c * 0.25;
            const Vec3d origin = unit(rng) * uniform(rng, 8, 15);
            const Vec3d d = engine::normalize(target - origin) * log_uniform(rng, 1e-6, 1e6);
            rays.push_back(Ray{origin, d});
        }
        return rays;
    };
    auto out = both_paths("direction lengths", s, make_rays(s), closed);
    for (auto& cs : embree_only("direction lengths (mesh)", big, make_rays(big), big_closed)) {
        out.push_back(std::move(cs));
    }
    return out;
}

std::vector<StressCase> near_ties(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 11);
    Scene s = empty_scene();
    // Parallel square pairs (two triangles each would double the count: one big triangle each),
    // k ulps apart along z; the farther one comes first in object order half of the time.
    const double z = 7.0;
    const int ks[] = {0, 1, 3, 8, 16, 64};
    for (int i = 0; i < 6; ++i) {
        const double zb = 20.0 * i + z;
        double z2 = zb;
        for (int k = 0; k < ks[i]; ++k)
            z2 = engine::next_up(z2);
        const Vec3d a{-10, -10, 0}, b{30, -10, 0}, c{-10, 30, 0};
        const Vec3d lo{0, 0, zb}, hi{0, 0, z2};
        if (i % 2 == 0) {
            s.objects.push_back(triangle(a + hi, b + hi, c + hi, "far " + std::to_string(i)));
            s.objects.push_back(triangle(a + lo, b + lo, c + lo, "near " + std::to_string(i)));
        } else {
            s.objects.push_back(triangle(a + lo, b + lo, c + lo, "near " + std::to_string(i)));
            s.objects.push_back(triangle(a + hi, b + hi, c + hi, "far " + std::to_string(i)));
        }
    }
    // Two spheres touching at (0, 0, 150) and the rays through the contact point.
    s.objects.push_back(sphere({0, 0, 148}, 2));
    s.objects.push_back(sphere({0, 0, 153}, 3));
    std::vector<Ray> rays;
    for (int i = 0; i < g.rays; ++i) {
        if (i % 5 == 4) {
            const Vec3d target{0, 0, 150};
            rays.push_back(ray_to(target + Vec3d{uniform(rng, -3, 3), uniform(rng, -3, 3), 0} +
                                      Vec3d{0, 0, -uniform(rng, 1, 5)},
                                  target));
            continue;
        }
        const int pair = uniform_int(rng, 0, 5);
        // From below the pair's near plane, steeply upwards, hitting inside both.
        const Vec3d origin{uniform(rng, 0, 5), uniform(rng, 0, 5),
                           20.0 * pair + uniform(rng, 1, 6)};
        const Vec3d d{uniform(rng, -0.3, 0.3), uniform(rng, -0.3, 0.3), 1};
        rays.push_back(Ray{origin, d});
    }
    return both_paths("near ties", std::move(s), std::move(rays));
}

std::vector<StressCase> far_mesh_spheres(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 12);
    std::vector<StressCase> out;
    for (int k = 3; k <= 9; k += 2) {
        Scene s = empty_scene();
        const Vec3d c = unit(rng) * std::pow(10.0, k);
        s.objects.push_back(engine::testing::icosphere_object(3, c, 1.0));
        std::vector<Ray> rays;
        for (int i = 0; i < g.rays / 2; ++i) {
            const Vec3d origin{uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)};
            const Vec3d axis = engine::normalize(c - origin);
            const Vec3d target = c + perpendicular(rng, axis) * std::sqrt(uniform(rng, 0, 0.9));
            rays.push_back(ray_to(origin, target));
        }
        for (auto& cs : embree_only("far spheres (mesh)", std::move(s), std::move(rays), {true})) {
            out.push_back(std::move(cs));
        }
    }
    return out;
}

std::vector<StressCase> far_origins(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 13);
    std::vector<StressCase> out;
    for (double far : {1e10, 1e13, 1e16, 1e18, 1e20, 1e22}) {
        Scene s = empty_scene();
        const Vec3d c{uniform(rng, -3, 3), uniform(rng, -3, 3), uniform(rng, -3, 3)};
        s.objects.push_back(engine::testing::icosphere_object(3, c, 1.0));
        std::vector<Ray> rays;
        for (int i = 0; i < g.rays / 2; ++i) {
            const std::size_t axis = static_cast<std::size_t>(i % 3);
            const double sign = i % 2 ? 1.0 : -1.0;
            if (i % 4 < 2) {
                // Along an axis, within the sphere's outline: an exact line through it.
                Vec3d o = c;
                for (std::size_t j = 0; j < 3; ++j)
                    o[j] = c[j] + uniform(rng, -1.1, 1.1);
                o[axis] = c[axis] - sign * far;
                Vec3d d{0, 0, 0};
                d[axis] = sign * log_uniform(rng, 0.01, 100);
                rays.push_back(Ray{o, d});
            } else {
                const Vec3d o = c + unit(rng) * far;
                rays.push_back(ray_to(o, c + unit(rng) * uniform(rng, 0, 1.2)));
            }
        }
        for (auto& cs : embree_only("far origins", std::move(s), std::move(rays), {true}))
            out.push_back(std::move(cs));
    }
    // A scene of four primitives, answered by brute force (linear_accel.h: moved to the scene
    // too since 2026-12-05; before, a lone triangle missed lines crossing it from 1e18 away).
    for (double far : {1e10, 1e14, 1e18, 1e22}) {
        Scene s = empty_scene();
        const Vec3d c{uniform(rng, -3, 3), uniform(rng, -3, 3), uniform(rng, -3, 3)};
        s.objects.push_back(sphere(c + Vec3d{0, 0, 1}, 0.75));
        s.objects.push_back(
            triangle(c + Vec3d{-1, -1, 0}, c + Vec3d{1, -1, 0}, c + Vec3d{-1, 1, 0}));
        s.objects.push_back(triangle(c + Vec3d{1, -1, 0}, c + Vec3d{1, 1, 0}, c + Vec3d{-1, 1, 0}));
        s.objects.push_back(sphere(c + Vec3d{1.5, 1.5, -0.5}, 0.25));
        std::vector<Ray> rays;
        for (int i = 0; i < g.rays / 4; ++i) {
            const Vec3d o = c + unit(rng) * far;
            // Aimed at points of the square and the spheres and a little beyond them.
            const Vec3d target = c + Vec3d{uniform(rng, -1.3, 1.3), uniform(rng, -1.3, 1.3),
                                           uniform(rng, -0.6, 1.8)};
            rays.push_back(ray_to(o, target));
        }
        out.push_back({"far origins (small)", std::make_shared<Scene>(std::move(s)),
                       std::move(rays), std::vector<bool>(4, false)});
    }
    return out;
}

std::vector<StressCase> many_objects(const GenOptions& g) {
    Rng rng(g.seed * 1000 + 14);
    Scene s = empty_scene();
    s.objects.push_back(engine::testing::mesh_object("empty first", {}, {}));
    std::vector<Vec3d> centres;
    for (int i = 0; i < 3; ++i) {
        centres.push_back({3.0 * i - 3.0, uniform(rng, -1, 1), uniform(rng, -1, 1)});
        s.objects.push_back(engine::testing::icosphere_object(2, centres.back(), 1.0));
        s.objects.push_back(engine::testing::mesh_object("empty", {}, {}));
    }
    for (int i = 0; i < 20; ++i) {
        s.objects.push_back(sphere({uniform(rng, -5, 5), uniform(rng, 2, 4), uniform(rng, -2, 2)},
                                   uniform(rng, 0.1, 0.5)));
        s.objects.push_back(
            triangle({uniform(rng, -5, 5), uniform(rng, -4, -2), uniform(rng, -2, 2)},
                     {uniform(rng, -5, 5), uniform(rng, -4, -2), uniform(rng, -2, 2)},
                     {uniform(rng, -5, 5), uniform(rng, -4, -2), uniform(rng, -2, 2)}));
    }
    s.objects.push_back(engine::testing::mesh_object("empty last", {}, {}));
    std::vector<bool> closed(s.objects.size(), false);
    std::vector<Ray> rays;
    for (int i = 0; i < 3; ++i) {
        const std::size_t object = 1 + 2 * static_cast<std::size_t>(i);
        closed[object] = true;
        const Vec3d c = centres[static_cast<std::size_t>(i)];
        auto edges = edge_and_vertex_rays(rng, *s.objects[object].mesh, g.rays / 4, 3.0,
                                          [&](const Vec3d& p) { return engine::normalize(p - c); });
        rays.insert(rays.end(), edges.begin(), edges.end());
    }
    // The rest from around the scene at random points of its spheres' and triangles' extent.
    while (rays.size() < static_cast<std::size_t>(g.rays)) {
        const Vec3d o{uniform(rng, -8, 8), uniform(rng, -8, 8), uniform(rng, -8, 8)};
        rays.push_back(ray_to(o, {uniform(rng, -5, 5), uniform(rng, -4, 4), uniform(rng, -2, 2)}));
    }
    return embree_only("many objects", std::move(s), std::move(rays), std::move(closed));
}

std::vector<StressCase> all_suites(const GenOptions& g, const std::string& shared_dir) {
    std::vector<StressCase> out;
    auto add = [&](std::vector<StressCase> v) {
        for (auto& c : v)
            out.push_back(std::move(c));
    };
    add(far_spheres(g));
    add(tiny_spheres(g));
    add(tangent_rays(g));
    add(mesh_edges(g));
    add(closed_models(g, shared_dir));
    add(slivers(g));
    add(huge_coordinates(g));
    add(nearly_parallel(g));
    add(origin_on_surface(g));
    add(direction_lengths(g));
    add(near_ties(g));
    add(far_mesh_spheres(g));
    add(far_origins(g));
    return out;
}

}  // namespace raycastd::stress
