// accuracy_report: every stress suite through QueryEngine at every precision, timed and judged
// against the quad-precision reference; the numbers behind docs/accuracy.md. Run by
// bench/accuracy, which adds Open3D's RaycastingScene on the triangle cases written here.
//
//   accuracy_report --out DIR [--rays N] [--repeats R] [--shared DIR]
//   accuracy_report --explain CASE_FILE    (one saved case, ray by ray: the engine's answers
//                                           and the reference's crossings; for bug reports)
//
// Writes DIR/accuracy.json (per suite, path and mode: rays, judged, near-ties, wrong decisions,
// leaks, max/median error in t, seconds) and, for every case made of triangles only, the files
// the Open3D peer reads (little-endian, no headers):
//   <stem>_vertices.f64   n×3 positions          <stem>_triangles.u32  m×3 indices
//   <stem>_tri_object.u32 object of each triangle <stem>_tri_prim.u32   its primitive index
//   <stem>_rays.f64       k×8 (origin, direction, tmin, tmax)
//   <stem>_ref.f64        k×6 per ray under the float bands: hit_robust, hit, object,
//                         object_robust, first_on_closed, t_first_robust
//   <stem>_crossings.f64  rows of 8: ray, object, primitive, t, margin, t_scale, tie band,
//                         parallel (1: the line runs alongside the triangle; never a hit)

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "engine/accel/linear_accel.h"
#include "tests/stress/case_file.h"
#include "tests/stress/generators.h"

namespace {

using raycastd::stress::ModeStats;
using raycastd::stress::StressCase;

template <class T>
void write_raw(const std::filesystem::path& file, const std::vector<T>& v) {
    std::ofstream out(file, std::ios::binary);
    out.write(reinterpret_cast<const char*>(v.data()),
              static_cast<std::streamsize>(v.size() * sizeof(T)));
}

std::string json_string(const std::string& s) {
    std::string out = "\"";
    for (char ch : s) {
        if (ch == '"' || ch == '\\')
            out += '\\';
        out += ch;
    }
    return out + "\"";
}

/// A number for JSON; an infinite error (a nonzero t against a reference of exactly 0) is
/// written as Infinity, which Python's json module reads.
std::string num(double v) {
    if (std::isinf(v))
        return v > 0 ? "Infinity" : "-Infinity";
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

std::string stats_json(const std::string& suite, const ModeStats& m) {
    char buf[1024];
    std::snprintf(buf, sizeof buf,
                  "{\"suite\": %s, \"path\": %s, \"mode\": %s, \"rays\": %zu, \"judged\": %zu, "
                  "\"near_ties\": %zu, \"near_tie_disagree\": %zu, \"wrong_hit\": %zu, "
                  "\"wrong_object\": %zu, \"leaks\": %zu, \"t_err_violations\": %zu, "
                  "\"max_rel\": %s, \"median_rel\": %s, \"max_ulps\": %s, "
                  "\"median_ulps\": %s, \"seconds\": %.9g}",
                  json_string(suite).c_str(), json_string(m.path).c_str(),
                  json_string(m.mode).c_str(), m.rays, m.judged, m.near_ties, m.near_tie_disagree,
                  m.wrong_hit, m.wrong_object, m.leaks, m.t_err_violations,
                  num(m.max_rel()).c_str(), num(m.median_rel()).c_str(), num(m.max_ulps()).c_str(),
                  num(m.median_ulps()).c_str(), m.seconds);
    return buf;
}

bool triangles_only(const StressCase& c) {
    for (const auto& o : c.scene->objects) {
        if (o.kind == raycastd::engine::ObjectKind::sphere)
            return false;
    }
    return true;
}

/// Whether Open3D can take the case's rays: it hands them to Embree as floats, and Debian's
/// Embree (built with assertions) aborts the process on a ray with a coordinate past ~1.8e18
/// (its ray-validity assertion), which the `far origins` suite has.
bool within_embree_float_range(const StressCase& c) {
    for (const auto& r : c.rays) {
        if (raycastd::engine::max_abs(r.origin) > 1e18 ||
            raycastd::engine::max_abs(r.direction) > 1e18)
            return false;
    }
    return true;
}

/// Writes the files of one triangle case for the Open3D peer.
void export_case(const StressCase& c, const std::filesystem::path& dir, const std::string& stem) {
    using namespace raycastd;
    std::vector<double> vertices;
    std::vector<std::uint32_t> tris, tri_object, tri_prim;
    for (std::uint32_t i = 0; i < c.scene->objects.size(); ++i) {
        const engine::TriangleMesh& m = *c.scene->objects[i].mesh;
        const auto base = static_cast<std::uint32_t>(vertices.size() / 3);
        for (const auto& p : m.positions)
            vertices.insert(vertices.end(), {p.x, p.y, p.z});
        for (std::uint32_t t = 0; t < m.size(); ++t) {
            for (auto k : m.triangles[t])
                tris.push_back(base + k);
            tri_object.push_back(i);
            tri_prim.push_back(t);
        }
    }
    std::vector<double> rays, ref, crossings;
    const stress::ReferenceAnswers answers = stress::reference_answers(c);
    const stress::Bands bands = stress::float_bands();
    for (std::size_t r = 0; r < c.rays.size(); ++r) {
        const engine::Ray& ray = c.rays[r];
        rays.insert(rays.end(), {ray.origin.x, ray.origin.y, ray.origin.z, ray.direction.x,
                                 ray.direction.y, ray.direction.z, ray.tmin, ray.tmax});
        const stress::RefAnswer& a = answers.coarse[r];
        ref.insert(ref.end(),
                   {double(a.hit_robust), double(a.hit), double(a.object), double(a.object_robust),
                    double(a.first_on_closed), stress::to_double(a.t_first_robust)});
        for (const stress::RefCrossing& x : a.crossings) {
            const double t = stress::to_double(x.t);
            const double tie = std::max(bands.tie_ulps * stress::ulp(t), bands.tie_rel * x.t_scale);
            crossings.insert(crossings.end(), {double(r), double(x.object), double(x.primitive), t,
                                               x.margin, x.t_scale, tie, double(x.parallel)});
        }
    }
    write_raw(dir / (stem + "_vertices.f64"), vertices);
    write_raw(dir / (stem + "_triangles.u32"), tris);
    write_raw(dir / (stem + "_tri_object.u32"), tri_object);
    write_raw(dir / (stem + "_tri_prim.u32"), tri_prim);
    write_raw(dir / (stem + "_rays.f64"), rays);
    write_raw(dir / (stem + "_ref.f64"), ref);
    write_raw(dir / (stem + "_crossings.f64"), crossings);
}

/// Prints, for every ray of a saved case, each precision's closest hit and the reference's
/// crossings (exact bands) with their margins.
int explain(const std::string& file) {
    using namespace raycastd;
    std::ifstream in(file);
    std::stringstream text;
    text << in.rdbuf();
    StressCase c;
    std::string error;
    if (!in || !stress::read_case(text.str(), c, error)) {
        std::fprintf(stderr, "%s: %s\n", file.c_str(), in ? error.c_str() : "cannot read");
        return 1;
    }
    auto built = engine::QueryEngine::build(c.scene);
    if (!built.ok()) {
        std::fprintf(stderr, "%s: %s\n", file.c_str(), built.status().message.c_str());
        return 1;
    }
    const auto& e = **built;
    std::printf("%zu objects, %zu primitives, path %s\n", c.scene->objects.size(),
                stress::primitive_count(*c.scene), e.brute_force() ? "brute force" : "embree");
    for (std::size_t i = 0; i < c.rays.size(); ++i) {
        const engine::Ray& r = c.rays[i];
        std::printf("ray %zu: o = (%a, %a, %a) d = (%a, %a, %a) [%g, %g]\n", i, r.origin.x,
                    r.origin.y, r.origin.z, r.direction.x, r.direction.y, r.direction.z, r.tmin,
                    r.tmax);
        for (auto p :
             {engine::Precision::fast, engine::Precision::refined, engine::Precision::exact}) {
            engine::QueryOptions opt;
            opt.precision = p;
            const auto res = e.intersect({r}, opt);
            const engine::Hit& h = res.hits[0];
            opt.mode = engine::Mode::count;
            const auto cnt = e.intersect({r}, opt);
            if (h.valid()) {
                std::printf("  %-8s hit object %u primitive %u t = %.17g (t_err %.3g), count %u\n",
                            engine::to_string(p), h.object, h.primitive, h.t, h.t_err,
                            cnt.counts[0]);
            } else {
                std::printf("  %-8s miss, count %u\n", engine::to_string(p), cnt.counts[0]);
            }
        }
        if (auto h = engine::linear_closest(*c.scene, r, false)) {
            std::printf("  brute force (linear_closest) object %u primitive %u t = %.17g\n",
                        h->object, h->primitive, h->t);
        } else {
            std::printf("  brute force (linear_closest) miss\n");
        }
        const auto a = stress::reference_closest(*c.scene, r, stress::exact_bands(), c.closed);
        std::printf("  reference: %s object %u primitive %u t = %.17g; hit %s, object %s\n",
                    a.hit ? "hit" : "miss", a.object, a.primitive, stress::to_double(a.t),
                    a.hit_robust ? "robust" : "near-tie", a.object_robust ? "robust" : "near-tie");
        for (const auto& x : a.crossings) {
            std::printf("    object %u primitive %u t = %.17g margin %.3g %s%s\n", x.object,
                        x.primitive, stress::to_double(x.t), x.margin,
                        x.front_face ? "front" : "back", x.parallel ? " parallel" : "");
        }
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    std::filesystem::path out_dir;
    std::string shared = RAYCASTD_SHARED_DIR;
    raycastd::stress::GenOptions g;
    g.rays = 2000;
    int repeats = 5;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const bool has_value = i + 1 < argc;
        if (a == "--explain" && has_value) {
            return explain(argv[++i]);
        } else if (a == "--out" && has_value) {
            out_dir = argv[++i];
        } else if (a == "--rays" && has_value) {
            g.rays = std::atoi(argv[++i]);
        } else if (a == "--repeats" && has_value) {
            repeats = std::atoi(argv[++i]);
        } else if (a == "--shared" && has_value) {
            shared = argv[++i];
        } else {
            std::fprintf(stderr,
                         "usage: accuracy_report --out DIR [--rays N] [--repeats R] "
                         "[--shared DIR]\n");
            return 2;
        }
    }
    if (out_dir.empty()) {
        std::fprintf(stderr, "accuracy_report: --out DIR is required\n");
        return 2;
    }
    std::filesystem::create_directories(out_dir / "open3d");
    const auto cases = raycastd::stress::all_suites(g, shared);

    std::string json = "{\"rays_per_case\": " + std::to_string(g.rays) + ",\n \"suites\": [\n";
    bool first = true;
    for (const auto& s : raycastd::stress::evaluate_suites(cases, repeats)) {
        std::fprintf(stderr, "%-40s %s\n", s.suite.c_str(), s.stats.summary().c_str());
        json += (first ? "  " : ",\n  ") + stats_json(s.suite, s.stats);
        first = false;
    }
    json += "\n ],\n \"open3d_cases\": [\n";
    first = true;
    int index = 0;
    for (const StressCase& c : cases) {
        if (!triangles_only(c) || !within_embree_float_range(c))
            continue;
        const std::string stem = "case" + std::to_string(index++);
        export_case(c, out_dir / "open3d", stem);
        json += (first ? "  " : ",\n  ") + std::string("{\"suite\": ") + json_string(c.suite) +
                ", \"stem\": " + json_string(stem) +
                ", \"rays\": " + std::to_string(c.rays.size()) +
                ", \"triangles\": " + std::to_string(c.scene->triangle_count()) + "}";
        first = false;
    }
    json += "\n ]}\n";
    std::ofstream(out_dir / "accuracy.json") << json;
    std::fprintf(stderr, "wrote %s\n", (out_dir / "accuracy.json").c_str());
    return 0;
}
