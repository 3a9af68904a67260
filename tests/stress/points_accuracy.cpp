// points_accuracy: the point queries (distance, signed distance) through QueryEngine, judged
// against the quad-precision reference of point_reference.h; the numbers behind the point-query
// section of docs/accuracy.md. Run by bench/accuracy_points.py, which adds Open3D's
// RaycastingScene.compute_distance / compute_signed_distance on the files written here.
//
//   points_accuracy --out DIR [--points N]
//
// Writes DIR/points_accuracy.json (per suite: points; the error of the engine's distance to the
// primitive it reports against the quad distance to that primitive, in ulps of the distance
// (points at least 0.1·scale off the surface) and in units of u·scale (all points); the error of
// the answer against the quad distance to the whole mesh over its bound (≤ 2: a tie within the
// bounds goes to the lower primitive, docs/api.md); points
// put on the surface that are not, judged signs and sign errors, ns a point) and per suite,
// little-endian without headers:
//   <stem>_vertices.f64 n×3   <stem>_triangles.u32 m×3   <stem>_points.f64 k×3
//   <stem>_ref.f64 k×3: reference distance, winding number, judged (1: the sign is judged)
//
// Judging: a distance is compared where the engine reports it off the surface (> 0); a point the
// engine puts on the surface (distance 0) must be within its bound γ₁₆·scale of it. A sign is
// judged off the surface (reference distance > 10⁻⁹·scale) and, on a mesh with holes, where the
// reference winding number is more than 10⁻² from ½ (docs/api.md: the fast winding numbers' error
// is below 5·10⁻³). scale = the largest coordinate magnitude of the point and the mesh.

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>
#include <quadmath.h>
#include <tbb/parallel_for.h>

#include "engine/math/float_bounds.h"
#include "engine/mesh/test_models.h"
#include "engine/points/point_queries.h"
#include "engine/testing/point_meshes.h"
#include "engine/testing/surface_points.h"
#include "tests/stress/point_reference.h"

namespace {

namespace re = raycastd::engine;
namespace rs = raycastd::stress;

struct Suite {
    std::string name, stem;
    re::Object object;
    std::vector<re::Vec3d> points;
};

/// n points uniform in the object's bounds scaled 1.5× about their centre.
std::vector<re::Vec3d> uniform(const re::Object& o, std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-0.75, 0.75);
    const re::Bounds3 b = o.mesh->bounds();
    const re::Vec3d c = b.center(), d = b.diagonal();
    std::vector<re::Vec3d> out(n);
    for (auto& p : out)
        p = c + re::Vec3d{u(rng) * d.x, u(rng) * d.y, u(rng) * d.z};
    return out;
}

/// Points at |p| = 1 ± 10^x (x uniform in [−9, −2]), or at 10^x (x in [2, 6]) for `far`.
std::vector<re::Vec3d> radial(std::size_t n, bool far, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> g;
    std::uniform_real_distribution<double> x(far ? 2 : -9, far ? 6 : -2), sign(-1, 1);
    std::vector<re::Vec3d> out(n);
    for (auto& p : out) {
        const re::Vec3d dir = normalize(re::Vec3d{g(rng), g(rng), g(rng)});
        const double r =
            far ? std::pow(10.0, x(rng)) : 1.0 + (sign(rng) < 0 ? -1 : 1) * std::pow(10.0, x(rng));
        p = dir * r;
    }
    return out;
}

/// Vertices, edge midpoints and centroids of the mesh, as computed in double, and the same moved
/// 1e-13 along ±x.
std::vector<re::Vec3d> on_surface(const re::TriangleMesh& m, std::size_t n) {
    std::vector<re::Vec3d> out;
    for (std::size_t i = 0; out.size() < n && i < m.size(); i += 3) {
        const re::Triangle t = m.triangle(i);
        for (const re::Vec3d& p : {t.a, (t.a + t.b) * 0.5, (t.a + t.b + t.c) / 3.0})
            out.insert(out.end(), {p, p + re::Vec3d{1e-13, 0, 0}, p - re::Vec3d{1e-13, 0, 0}});
    }
    out.resize(std::min(out.size(), n));
    return out;
}

/// One closed mesh of many components (the parity test counts each component only where its box
/// holds the point, engine/mesh/components.h): 18 icospheres of level 2 and radius 0.35 at the
/// integer points (0..2, 0..2, 0..1), and a hollow ball about (1, 1, 2.6), its outer surface of
/// radius 0.5 facing out and its inner one of radius 0.3 facing in, so that the winding number
/// the reference sums (1 in the ball's wall, 0 in its cavity) is the parity truth.
re::Object sphere_field() {
    std::vector<re::testing::Ball> balls;
    for (int k = 0; k < 2; ++k)
        for (int j = 0; j < 3; ++j)
            for (int i = 0; i < 3; ++i)
                balls.push_back({{double(i), double(j), double(k)}, 0.35});
    balls.push_back({{1, 1, 2.6}, 0.5});
    balls.push_back({{1, 1, 2.6}, 0.3, true});
    re::Object o = re::testing::balls_object(balls, 2);
    o.name = "field";
    return o;
}

/// n points near the field's mesh: a uniform point of a random triangle moved along the
/// triangle's unit normal by ±10^x, x uniform in [−9, −2] (off the mesh itself, not off the
/// spheres it approximates, whose level-2 faces lie up to 1.3% of a radius inside them).
std::vector<re::Vec3d> field_shell(const re::Object& field, std::size_t n, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    const re::TriangleMesh& m = *field.mesh;
    std::uniform_real_distribution<double> u(0, 1), x(-9, -2), sign(-1, 1);
    std::uniform_int_distribution<std::size_t> pick(0, m.size() - 1);
    std::vector<re::Vec3d> out(n);
    for (auto& p : out) {
        const re::Triangle t = m.triangle(pick(rng));
        const double r1 = u(rng), r2 = u(rng);
        const re::Vec3d on = re::testing::uniform_on_triangle(t.a, t.b, t.c, r1, r2);
        const re::Vec3d normal = normalize(cross(t.b - t.a, t.c - t.a));
        p = on + normal * ((sign(rng) < 0 ? -1 : 1) * std::pow(10.0, x(rng)));
    }
    return out;
}

std::vector<Suite> suites(std::size_t n) {
    std::vector<Suite> s;
    const re::Object ico5 = re::testing::icosphere_object(5);
    s.push_back({"icosphere L5, uniform in 1.5× bounds", "ico_uniform", ico5, uniform(ico5, n, 1)});
    s.push_back({"icosphere L5, shell 10⁻⁹…10⁻² off the unit sphere", "ico_shell", ico5,
                 radial(n, false, 2)});
    s.push_back({"icosphere L5, on the surface (vertices, edge midpoints, centroids, ±1e-13)",
                 "ico_surface", ico5, on_surface(*ico5.mesh, n)});
    s.push_back({"icosphere L5, far (10²…10⁶ away)", "ico_far", ico5, radial(n / 2, true, 3)});
    const re::Object off = re::testing::icosphere_object(4, {1e5, -2e5, 3e5});
    s.push_back(
        {"icosphere L4 at (1e5, −2e5, 3e5), uniform", "ico_offset", off, uniform(off, n, 4)});
    if (auto spot = re::testing::model_object("spot/spot.obj"))
        s.push_back({"spot.obj (closed model), uniform", "spot", *spot, uniform(*spot, n, 5)});
    const re::Object field = sphere_field();
    s.push_back({"20 icospheres in one mesh (a hollow ball among them), uniform", "field", field,
                 uniform(field, n, 10)});
    s.push_back({"20 icospheres in one mesh, 10⁻⁹…10⁻² off their triangles", "field_shell", field,
                 field_shell(field, n, 11)});
    re::Object holes = re::testing::icosphere_object(4);
    auto m = std::make_shared<re::TriangleMesh>(*holes.mesh);
    m->triangles.erase(m->triangles.begin() + 100, m->triangles.begin() + 110);
    holes.mesh = m;
    s.push_back({"icosphere L4 with 10 triangles removed (holes), uniform", "ico_holes", holes,
                 uniform(holes, n, 6)});
    const re::Object open = re::testing::open_cube_object(0, 1);
    s.push_back({"cube with a face removed, uniform", "open_cube", open, uniform(open, n, 7)});
    const re::Object flipped = re::testing::flipped_cube_object(0, 1);
    s.push_back(
        {"cube with a flipped triangle, uniform", "flipped_cube", flipped, uniform(flipped, n, 8)});
    if (auto bunny = re::testing::model_object("bunny_ply/bunny.ply"))
        s.push_back({"Stanford bunny (5 holes), uniform", "bunny", *bunny, uniform(*bunny, n, 9)});
    return s;
}

/// count values of T to `file`, raw (little-endian on every machine we build for).
template <class T>
void write_raw(const std::filesystem::path& file, const T* data, std::size_t count) {
    std::ofstream(file, std::ios::binary)
        .write(reinterpret_cast<const char*>(data),
               static_cast<std::streamsize>(count * sizeof(T)));
}

nlohmann::json run_suite(const Suite& s, const std::filesystem::path& dir) {
    re::Scene scene = re::testing::scene_of({s.object});
    auto built = re::QueryEngine::build(std::make_shared<re::Scene>(scene));
    if (!built.ok())
        return {{"suite", s.name}, {"error", built.status().message}};
    const re::QueryEngine& e = **built;
    const re::TriangleMesh& mesh = *e.scene().objects[0].mesh;
    const std::size_t n = s.points.size();
    std::vector<re::PointAnswer> dist, sd;
    (void)re::query_points(e, s.points, {re::PointQuery::distance, re::kInfinity, {}}, dist);
    const auto td = std::chrono::steady_clock::now();
    (void)re::query_points(e, s.points, {re::PointQuery::distance, re::kInfinity, {}}, dist);
    const auto t0 = std::chrono::steady_clock::now();
    (void)re::query_points(e, s.points, {re::PointQuery::signed_distance, re::kInfinity, {}}, sd);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double distance_seconds = std::chrono::duration<double>(t0 - td).count();

    std::vector<double> ref(3 * n), own(n);
    double mesh_scale = 0;
    for (const re::Vec3d& v : mesh.positions)
        mesh_scale = std::max(mesh_scale, re::max_abs(v));
    tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
        const re::Vec3d& p = s.points[i];
        const double scale = std::max(mesh_scale, re::max_abs(p));
        const double d = rs::to_double(rs::reference_distance(mesh, p));
        const double w = rs::reference_winding(mesh, p);
        const bool parity = e.topology()[0].sign == re::SignMethod::parity;
        ref[3 * i] = d;
        if (dist[i].hit.valid())
            own[i] = rs::to_double(
                rs::reference_triangle_distance(mesh.triangle(dist[i].hit.primitive), p));
        ref[3 * i + 1] = w;
        ref[3 * i + 2] = d > 1e-9 * scale && (parity || std::abs(w - 0.5) > 1e-2);
    });
    double max_ulps = 0, max_uscale = 0, max_err_bound = 0;
    std::size_t compared = 0, far = 0, judged = 0, sign_errors = 0, surface_points = 0,
                wrong_surface = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const re::Vec3d& p = s.points[i];
        const double scale = std::max(mesh_scale, re::max_abs(p));
        const double d = dist[i].distance, d_ref = ref[3 * i];
        if (d == 0) {
            ++surface_points;
            wrong_surface += !(d_ref <= re::gamma(16) * scale);
        } else {
            ++compared;
            const double err = std::abs(d - own[i]);
            // ulps of the distance where it is not small next to the coordinates (near a surface
            // the error is some u·scale, however small the distance: the next column).
            far += own[i] >= 0.1 * scale;
            if (own[i] >= 0.1 * scale)
                max_ulps = std::max(max_ulps, err / (std::nextafter(own[i], 1e300) - own[i]));
            max_uscale = std::max(max_uscale, err / (re::kDoubleUnitRoundoff * scale));
            max_err_bound = std::max(max_err_bound, std::abs(d - d_ref) / dist[i].hit.err);
        }
        if (ref[3 * i + 2] != 0) {
            ++judged;
            sign_errors += (sd[i].distance < 0 || (sd[i].distance == 0)) != (ref[3 * i + 1] > 0.5);
        }
    }
    const re::Bounds3 b = mesh.bounds();
    std::vector<std::uint32_t> tris;
    for (const auto& t : mesh.triangles)
        tris.insert(tris.end(), t.begin(), t.end());
    // Through data(): `&v[0]` of an empty vector (`--points 0`, a mesh with no vertices) is UB.
    write_raw(dir / (s.stem + "_vertices.f64"),
              reinterpret_cast<const double*>(mesh.positions.data()), 3 * mesh.positions.size());
    write_raw(dir / (s.stem + "_triangles.u32"), tris.data(), tris.size());
    write_raw(dir / (s.stem + "_points.f64"), reinterpret_cast<const double*>(s.points.data()),
              3 * n);
    write_raw(dir / (s.stem + "_ref.f64"), ref.data(), ref.size());
    return {{"suite", s.name},
            {"stem", s.stem},
            {"triangles", mesh.size()},
            {"sign", re::to_string(e.topology()[0].sign)},
            {"points", n},
            {"compared", compared},
            {"max_ulps", far ? nlohmann::json(max_ulps) : nlohmann::json(nullptr)},
            {"max_u_scale", max_uscale},
            {"max_error_over_bound", max_err_bound},
            {"on_surface", surface_points},
            {"wrong_on_surface", wrong_surface},
            {"judged_signs", judged},
            {"sign_errors", sign_errors},
            {"ns_per_point", seconds / std::max<std::size_t>(n, 1) * 1e9},
            {"ns_per_point_distance", distance_seconds / std::max<std::size_t>(n, 1) * 1e9},
            {"diagonal", length(b.diagonal())}};
}

}  // namespace

int main(int argc, char** argv) {
    std::filesystem::path out;
    std::size_t n = 4000;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--out" && i + 1 < argc) {
            out = argv[++i];
        } else if (a == "--points" && i + 1 < argc) {
            n = std::stoul(argv[++i]);
        } else {
            std::fprintf(stderr, "usage: points_accuracy --out DIR [--points N]\n");
            return 2;
        }
    }
    if (out.empty()) {
        std::fprintf(stderr, "usage: points_accuracy --out DIR [--points N]\n");
        return 2;
    }
    std::filesystem::create_directories(out);
    nlohmann::json doc = {{"suites", nlohmann::json::array()}};
    for (const Suite& s : suites(n)) {
        std::fprintf(stderr, "points_accuracy: %s\n", s.name.c_str());
        doc["suites"].push_back(run_suite(s, out));
    }
    std::ofstream(out / "points_accuracy.json") << doc.dump(1) << "\n";
    return 0;
}
