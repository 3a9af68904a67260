// bench_points: the point queries in-process (issue 18), and what topology costs a registration.
//
//   bench_points            full size: registration of workload B (1,024,000 triangles, binary
//                           PLY) with and without the topology; 1M query points against
//                           workload A (the 81,920-triangle icosphere): closest points, signed
//                           distance, occupancy; 1M points in a shell about A (radii 0.99-1.01):
//                           closest points and signed distance; 1M uniform points against B
//                           (closed, parity) and 1M within 0.01 of its surface: closest points
//                           and signed distance; 1M points'
//                           signed distance against B with one triangle removed (the
//                           winding-number path on 1M triangles)
//   bench_points --quick    small sizes (seconds)
//   bench_points --registration-only   the registration part alone
//   bench_points --smoke    tiny sizes, < 1 s; exits 1 if a signed distance disagrees with the
//                           sphere it approximates (the CTest `bench_points_smoke`)
//   bench_points --json F   also writes the registration and the side-by-side rows to F (what
//                           bench/run_all.py puts into docs/benchmarks.md)
//
// Besides in-process (not in --smoke), the same mesh and points go through two peers in the same
// run, and a table of the three closes the sections on A, its shell and B:
//   * raycastd's binary endpoint, POST /v1/scenes/{id}/points?dtype=float32, the server binary
//     (build/release/server/raycastd) on loopback (bench/peers/points_http_peer.py): wall time
//     from request to the answer's last byte, and the server process's CPU time;
//   * when Debian's python3-open3d is installed, Open3D's RaycastingScene.compute_closest_points
//     and compute_signed_distance (bench/peers/open3d_points_peer.py, with the Embree mask shim
//     preloaded: its sign comes from rays, which hit nothing without it; PERFORMANCE.md).
// On A each side's figure is the median of 3 calls after a warm-up (kPeerReps); on B the peers
// time one call after a warm-up call, and we one call with no warm-up (Open3D takes tens of
// seconds a call there; our first signed distance on B also builds the exact path's BVH and the
// parity pieces).
//
// Registration is timed in its parts, each the median of 3 runs after a warm-up: parse
// (load_model), validate, the Embree BVH (EmbreeAccel::build), the topology (compute_topology)
// and QueryEngine::build, which runs the last two one after the other. "Without topology" is
// parse + validate + BVH, what QueryEngine::build did before issue 18; "with" is parse +
// QueryEngine::build. Wall and CPU seconds are both printed: on a shared 2-core machine the CPU
// figures are the steadier ones.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "bench/bench_files.h"
#include "bench/timing.h"
#include "bench/workloads.h"
#include "engine/accel/embree_accel.h"
#include "engine/load/model_loader.h"
#include "engine/mesh/topology.h"
#include "engine/points/point_queries.h"
#include "engine/testing/surface_points.h"

namespace rb = raycastd::bench;
namespace re = raycastd::engine;

namespace {

struct Sizes {
    const char* name;
    int ico_level;       ///< A: 20·4^level triangles
    int field_count;     ///< B: this many icospheres ...
    int field_level;     ///< ... of this level
    std::size_t points;  ///< query points per measurement
};

constexpr Sizes kFull{"full", 6, 200, 4, std::size_t{1} << 20};
constexpr Sizes kQuick{"quick", 4, 50, 3, std::size_t{1} << 16};
constexpr Sizes kSmoke{"smoke", 3, 8, 2, 4096};
using rb::kFieldSeed;  // bench_intersect's workload B
constexpr std::uint64_t kPointSeed = 0x5eed0018;
/// Calls timed on A, ours and the peers': the median of this many after a warm-up.
constexpr int kPeerReps = 3;

double cpu_now() {
    return static_cast<double>(std::clock()) / CLOCKS_PER_SEC;
}

/// What --json writes: the registration's parts and each side-by-side row (bench/run_all.py
/// reads it into docs/benchmarks.md).
nlohmann::json g_report = nlohmann::json::object();

/// Wall and CPU seconds of one call.
struct Timed {
    double wall = 0, cpu = 0;
};
template <class F>
Timed timed(F&& f) {
    const double c0 = cpu_now();
    const double w = rb::seconds(f);
    return {w, cpu_now() - c0};
}
/// The median (by wall time) of 3 runs after a warm-up.
template <class F>
Timed median3(F&& f) {
    f();
    Timed t[3] = {timed(f), timed(f), timed(f)};
    std::sort(t, t + 3, [](const Timed& a, const Timed& b) { return a.wall < b.wall; });
    return t[1];
}

std::string file_bytes(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

void registration(const Sizes& s) {
    const rb::Workload w = rb::make_icosphere_field(s.field_count, s.field_level, kFieldSeed);
    const std::string path =
        (std::filesystem::temp_directory_path() / "bench_points_B.ply").string();
    if (!rb::write_ply(path, w)) {
        std::printf("cannot write %s\n", path.c_str());
        return;
    }
    const std::string bytes = file_bytes(path);
    std::filesystem::remove(path);
    std::shared_ptr<re::Scene> scene;
    const Timed parse = median3([&] {
        auto m = re::load_model(bytes, re::ModelFormat::ply, re::no_resources(), "B");
        scene = std::make_shared<re::Scene>();
        scene->materials.push_back(re::Material{});
        re::Object o;
        o.kind = re::ObjectKind::mesh;
        o.name = "B";
        o.mesh = std::make_shared<re::TriangleMesh>(std::move(m->parts.at(0).mesh));
        scene->objects.push_back(std::move(o));
    });
    const Timed validate = median3([&] { (void)re::validate(*scene); });
    const Timed bvh = median3([&] { (void)re::EmbreeAccel::build(*scene); });
    re::MeshTopology topo;
    const Timed topology = median3([&] { topo = re::compute_topology(*scene->objects[0].mesh); });
    const Timed build = median3([&] { (void)re::QueryEngine::build(scene); });
    const double without = parse.wall + validate.wall + bvh.wall;
    const double with = parse.wall + build.wall;
    const double without_cpu = parse.cpu + validate.cpu + bvh.cpu;
    const double with_cpu = parse.cpu + build.cpu;
    std::printf(
        "registration of B (%zu triangles, binary PLY %.1f MB), median of 3, wall / CPU ms:\n",
        scene->triangle_count(), bytes.size() / 1e6);
    std::printf(
        "  parse %.0f / %.0f   validate %.0f / %.0f   Embree BVH %.0f / %.0f   "
        "topology %.0f / %.0f   QueryEngine::build (topology, then BVH) %.0f / %.0f\n",
        parse.wall * 1e3, parse.cpu * 1e3, validate.wall * 1e3, validate.cpu * 1e3, bvh.wall * 1e3,
        bvh.cpu * 1e3, topology.wall * 1e3, topology.cpu * 1e3, build.wall * 1e3, build.cpu * 1e3);
    std::printf(
        "  without topology %.0f ms (CPU %.0f)   with %.0f ms (CPU %.0f)   growth %+.0f%% "
        "wall, %+.0f%% CPU\n",
        without * 1e3, without_cpu * 1e3, with * 1e3, with_cpu * 1e3, 100 * (with / without - 1),
        100 * (with_cpu / without_cpu - 1));
    g_report["registration"] = {
        {"triangles", scene->triangle_count()},      {"parse", {parse.wall, parse.cpu}},
        {"validate", {validate.wall, validate.cpu}}, {"bvh", {bvh.wall, bvh.cpu}},
        {"topology", {topology.wall, topology.cpu}}, {"build", {build.wall, build.cpu}},
        {"without", {without, without_cpu}},         {"with", {with, with_cpu}},
    };
    std::printf("  topology: V %zu, closed %d, components %zu, chi %lld, half-edge %d, sign %s\n",
                topo.vertices, topo.closed, topo.components,
                static_cast<long long>(topo.euler_characteristic), topo.half_edge,
                re::to_string(topo.sign));
}

/// n points uniform in the bounds scaled 1.5× about their centre, rounded to float so that a
/// float32 peer gets exactly the same points.
std::vector<re::Vec3d> random_points(const re::Bounds3& b, std::size_t n) {
    std::mt19937_64 rng(kPointSeed);
    std::uniform_real_distribution<double> u(-0.75, 0.75);
    const re::Vec3d c = b.center(), d = b.diagonal();
    std::vector<re::Vec3d> out(n);
    for (auto& p : out)
        p = re::Vec3d(re::Vec3f(c + re::Vec3d{u(rng) * d.x, u(rng) * d.y, u(rng) * d.z}));
    return out;
}

/// n points in a shell about the unit sphere (A's): uniform directions, radii uniform in
/// [0.99, 1.01], rounded to float like random_points.
std::vector<re::Vec3d> shell_points(std::size_t n) {
    std::mt19937_64 rng(kPointSeed + 1);
    std::normal_distribution<double> g;
    std::uniform_real_distribution<double> r(0.99, 1.01);
    std::vector<re::Vec3d> out(n);
    for (auto& p : out)
        p = re::Vec3d(re::Vec3f(re::normalize(re::Vec3d{g(rng), g(rng), g(rng)}) * r(rng)));
    return out;
}

/// n points within 0.01 of a workload's surface (the shell of A's radii 0.99–1.01 for B's spheres
/// of radius 0.5–1.5): a uniform triangle, a uniform point of it, moved along its normal by a
/// uniform offset in [−0.01, 0.01]; rounded to float like random_points.
std::vector<re::Vec3d> surface_shell_points(const rb::Workload& w, std::size_t n) {
    std::mt19937_64 rng(kPointSeed + 2);
    std::uniform_int_distribution<std::size_t> pick(0, w.triangles.size() - 1);
    std::uniform_real_distribution<double> u(0.0, 1.0), off(-0.01, 0.01);
    auto vertex = [&](std::uint32_t i) {
        const auto& v = w.positions[i];
        return re::Vec3d{v[0], v[1], v[2]};
    };
    std::vector<re::Vec3d> out(n);
    for (auto& p : out) {
        const auto& t = w.triangles[pick(rng)];
        const re::Vec3d a = vertex(t[0]), b = vertex(t[1]), c = vertex(t[2]);
        const double r1 = u(rng), r2 = u(rng);  // drawn in this order: the same points as before
        const re::Vec3d x = re::testing::uniform_on_triangle(a, b, c, r1, r2);
        p = re::Vec3d(re::Vec3f(x + re::normalize(re::cross(b - a, c - a)) * off(rng)));
    }
    return out;
}

/// Where the peers' files go, and the peers (an empty script or binary: no such peer this run).
struct Peer {
    std::string data_dir, shim, open3d_script, server, http_script;
};

/// One query's in-process figures.
struct Run {
    std::vector<re::PointAnswer> answers;
    Timed t;
};

/// Times one query over the points; returns the answers and the times. With reps > 1: the
/// median (by wall time) of that many calls after a warm-up, the statistic the peers report on
/// A (bench/peers/*.py --reps), so that a ratio compares like with like.
Run run(const re::QueryEngine& e, const std::vector<re::Vec3d>& pts, re::PointQuery q,
        const char* what, bool spatial_order = true, int reps = 1) {
    Run r;
    auto once = [&] {
        r.answers.clear();  // each call fills a fresh vector, as a request's does
        r.answers.shrink_to_fit();
        return timed([&] {
            (void)re::query_points(e, pts, re::PointOptions{q, re::kInfinity, {}, spatial_order},
                                   r.answers);
        });
    };
    if (reps > 1) {
        once();
        std::vector<Timed> t;
        for (int k = 0; k < reps; ++k)
            t.push_back(once());
        // Each median on its own, as the peers take them (bench/peers/open3d_points_peer.py).
        std::vector<double> wall, cpu;
        for (const Timed& x : t) {
            wall.push_back(x.wall);
            cpu.push_back(x.cpu);
        }
        std::sort(wall.begin(), wall.end());
        std::sort(cpu.begin(), cpu.end());
        r.t = {wall[wall.size() / 2], cpu[cpu.size() / 2]};
    } else {
        r.t = once();
    }
    std::printf(
        "  %-16s %-28s %8zu points  %7.3f s (CPU %7.3f s)  %6.2f Mpoints/s%s\n", re::to_string(q),
        what, pts.size(), r.t.wall, r.t.cpu, pts.size() / r.t.wall * 1e-6,
        reps > 1 ? ("  (median of " + std::to_string(reps) + " after a warm-up)").c_str() : "");
    return r;
}

/// Writes A's mesh (arrays and PLY), the points and our distances for the peers.
bool write_peer_files(const Peer& peer, const std::string& name, const rb::Workload& a,
                      const std::vector<re::Vec3d>& pts, const Run& dist, const Run& signed_dist) {
    std::filesystem::create_directories(peer.data_dir);
    const std::string stem = peer.data_dir + "/" + name;
    std::vector<float> p, d, sd;
    for (std::size_t i = 0; i < pts.size(); ++i) {
        p.insert(p.end(), {float(pts[i].x), float(pts[i].y), float(pts[i].z)});
        d.push_back(float(dist.answers[i].distance));
        sd.push_back(float(signed_dist.answers[i].distance));
    }
    return rb::write_mesh_arrays(stem, a) && rb::write_ply(stem + ".ply", a) &&
           rb::write_npy(stem + "_points.npy", p.data(), {pts.size(), 3}) &&
           rb::write_npy(stem + "_distance.npy", d.data(), {pts.size()}) &&
           rb::write_npy(stem + "_signed.npy", sd.data(), {pts.size()});
}

/// Runs one peer's command and returns the JSON object it printed (null if none).
nlohmann::json run_peer(const std::string& cmd, const char* name) {
    const std::string out = rb::command_output(cmd);
    std::printf("  %s (same points, same run): %s", name, out.c_str());
    auto j = nlohmann::json::parse(out, nullptr, /*allow_exceptions=*/false);
    return j.is_object() ? j : nlohmann::json(nullptr);
}

/// The table of in-process, the binary endpoint and Open3D for one query ("closest" or
/// "signed" in the peers' JSON); ratios are points/s against Open3D's.
void compare(const std::string& set, const char* what, const char* key, const Run& ours,
             const nlohmann::json& http, const nlohmann::json& o3d) {
    auto field = [&](const nlohmann::json& j, const char* f) {
        return j.is_object() && j.contains(key) ? j[key].value(f, 0.0) : 0.0;
    };
    const double o3d_wall = field(o3d, "seconds"), o3d_cpu = field(o3d, "cpu_seconds");
    const double http_wall = field(http, "seconds"), http_cpu = field(http, "server_cpu_seconds");
    auto pair = [](double wall, double cpu) {
        return wall > 0 ? nlohmann::json{wall, cpu} : nlohmann::json(nullptr);
    };
    g_report["points"].push_back({{"set", set},
                                  {"query", what},
                                  {"points", ours.answers.size()},
                                  {"ours", pair(ours.t.wall, ours.t.cpu)},
                                  {"endpoint", pair(http_wall, http_cpu)},
                                  {"open3d", pair(o3d_wall, o3d_cpu)}});
    std::printf("  %-16s in-process %.3f s (CPU %.3f)", what, ours.t.wall, ours.t.cpu);
    if (http_wall > 0)
        std::printf("   binary endpoint %.3f s (server CPU %.3f)", http_wall, http_cpu);
    if (o3d_wall > 0) {
        std::printf("   Open3D %.3f s (CPU %.3f)   in-process %.2fx Open3D (CPU %.2fx)", o3d_wall,
                    o3d_cpu, o3d_wall / ours.t.wall, o3d_cpu / ours.t.cpu);
        if (http_wall > 0)
            std::printf(", endpoint %.2fx (CPU %.2fx)", o3d_wall / http_wall, o3d_cpu / http_cpu);
    }
    std::printf("\n");
}

/// The peers on the points `name` and the mesh `a`, and the comparison table.
void run_peers(const Peer& peer, const std::string& name, const rb::Workload& a,
               const std::vector<re::Vec3d>& pts, const Run& dist, const Run& signed_dist,
               int reps = kPeerReps) {
    if (peer.open3d_script.empty() && peer.server.empty())
        return;
    if (!write_peer_files(peer, name, a, pts, dist, signed_dist)) {
        std::printf("  peers: cannot write their files to %s\n", peer.data_dir.c_str());
        return;
    }
    nlohmann::json http, o3d;
    if (!peer.server.empty()) {
        http = run_peer("/usr/bin/python3 " + peer.http_script + " --data-dir " + peer.data_dir +
                            " --binary " + peer.server + " --workload " + name + " --reps " +
                            std::to_string(reps),
                        "binary endpoint");
    }
    if (!peer.open3d_script.empty()) {
        o3d = run_peer("LD_PRELOAD=" + peer.shim + " /usr/bin/python3 " + peer.open3d_script +
                           " --data-dir " + peer.data_dir + " --workload " + name + " --reps " +
                           std::to_string(reps),
                       "open3d");
    }
    std::printf("  side by side (wall; CPU of every thread of the process):\n");
    compare(name, "closest", "closest", dist, http, o3d);
    compare(name, "signed_distance", "signed", signed_dist, http, o3d);
}

std::shared_ptr<const re::QueryEngine> prepare(re::Scene s) {
    auto e = re::QueryEngine::build(std::make_shared<re::Scene>(std::move(s)));
    return e.ok() ? *e : nullptr;
}

/// Builds the engine's point BVH (its first closest-point query) and prints its time and bytes.
void point_tree(const re::QueryEngine& e) {
    const std::size_t before = e.memory_bytes();
    const Timed t = timed([&] { (void)e.closest_point({0, 0, 0}, re::kInfinity); });
    const double bytes = static_cast<double>(e.memory_bytes() - before);
    std::printf(
        "  point BVH built on first use in %.3f s (CPU %.3f s): %.1f MB, %.0f B a triangle\n",
        t.wall, t.cpu, bytes / 1e6, bytes / static_cast<double>(e.scene().triangle_count()));
}

/// Points against A; returns the largest |signed distance − (|p| − 1)| (the icosphere is within
/// 1 − cos of its edge's half angle of the unit sphere), for the smoke check.
double points_on_a(const Sizes& s, const Peer& peer) {
    const rb::Workload a = rb::make_icosphere(s.ico_level);
    auto e = prepare(rb::to_engine_scene(a));
    const auto pts = random_points(e->scene().bounds(), s.points);
    std::printf("points against A (icosphere, %zu triangles, sign %s):\n", a.triangles.size(),
                re::to_string(e->topology()[0].sign));
    point_tree(*e);
    run(*e, pts, re::PointQuery::closest, "(first: no warm-up)");
    const Run closest = run(*e, pts, re::PointQuery::closest, "", true, kPeerReps);
    // The same points in the order given (the batch is otherwise taken in its spatial order:
    // engine/points/batch.h), to measure what that order gains in this run.
    run(*e, pts, re::PointQuery::closest, "(given order)", false);
    run(*e, pts, re::PointQuery::distance, "");
    const Run sd =
        run(*e, pts, re::PointQuery::signed_distance, "(parity rays, exact)", true, kPeerReps);
    run(*e, pts, re::PointQuery::occupancy, "");
    run_peers(peer, "A", a, pts, closest, sd);
    // A shell near the surface (issue 18's second point set): the nearest triangles are then
    // close and many compete within the same distance.
    const auto shell = shell_points(s.points);
    std::printf("points in a shell about A (radii 0.99 … 1.01):\n");
    const Run shell_closest = run(*e, shell, re::PointQuery::closest, "(shell)", true, kPeerReps);
    run(*e, shell, re::PointQuery::closest, "(shell, given order)", false);
    const Run shell_sd =
        run(*e, shell, re::PointQuery::signed_distance, "(shell, parity rays)", true, kPeerReps);
    run(*e, shell, re::PointQuery::signed_distance, "(shell, parity, given order)", false);
    run_peers(peer, "A_shell", a, shell, shell_closest, shell_sd);
    double worst = 0;
    for (std::size_t i = 0; i < pts.size(); ++i)
        worst = std::max(worst, std::abs(sd.answers[i].distance - (re::length(pts[i]) - 1.0)));
    for (std::size_t i = 0; i < shell.size(); ++i) {
        worst =
            std::max(worst, std::abs(shell_sd.answers[i].distance - (re::length(shell[i]) - 1.0)));
    }
    return worst;
}

/// Points against the whole of B (closed: parity signs), side by side with the peers: the issue's
/// second mesh, 1M triangles in 200 components. The peers time one call after their warm-up here
/// (Open3D takes tens of seconds a call on it).
void points_on_b(const Sizes& s, const Peer& peer) {
    const rb::Workload b = rb::make_icosphere_field(s.field_count, s.field_level, kFieldSeed);
    auto e = prepare(rb::to_engine_scene(b));
    const auto pts = random_points(e->scene().bounds(), s.points);
    std::printf("points against B (%zu triangles, sign %s):\n", b.triangles.size(),
                re::to_string(e->topology()[0].sign));
    point_tree(*e);
    const Run closest = run(*e, pts, re::PointQuery::closest, "");
    const Run sd = run(*e, pts, re::PointQuery::signed_distance, "(parity rays, exact)");
    run_peers(peer, "B", b, pts, closest, sd, 1);
    const auto shell = surface_shell_points(b, s.points);
    std::printf("points within 0.01 of B's surface:\n");
    const Run shell_closest = run(*e, shell, re::PointQuery::closest, "(shell)");
    const Run shell_sd = run(*e, shell, re::PointQuery::signed_distance, "(shell, parity rays)");
    run_peers(peer, "B_shell", b, shell, shell_closest, shell_sd, 1);
}

void winding_on_b(const Sizes& s) {
    rb::Workload b = rb::make_icosphere_field(s.field_count, s.field_level, kFieldSeed);
    b.triangles.pop_back();  // a hole: the winding-number path
    auto e = prepare(rb::to_engine_scene(b));
    const auto pts = random_points(e->scene().bounds(), s.points);
    std::printf("points against B minus one triangle (%zu triangles, sign %s):\n",
                b.triangles.size(), re::to_string(e->topology()[0].sign));
    point_tree(*e);
    const Timed tree = timed([&] { (void)e->winding_number(0, {0, 0, 0}); });
    std::printf("  winding-number tree built on first use in %.3f s\n", tree.wall);
    run(*e, pts, re::PointQuery::signed_distance, "(fast winding numbers)");
    run(*e, pts, re::PointQuery::occupancy, "");
}

}  // namespace

int main(int argc, char** argv) {
    Sizes s = kFull;
    bool registration_only = false;
    std::string json_path;
    const std::filesystem::path here = std::filesystem::path(argv[0]).parent_path();
    const std::string peers = std::string(RAYCASTD_SOURCE_DIR) + "/bench/peers/";
    Peer peer{(here / "points_peer_data").string(), (here / "libembree_mask_shim.so").string(),
              peers + "open3d_points_peer.py",
              (here.parent_path() / "server" / "raycastd").string(), peers + "points_http_peer.py"};
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--quick") {
            s = kQuick;
        } else if (a == "--smoke") {
            s = kSmoke;
        } else if (a == "--registration-only") {
            registration_only = true;
        } else if (a == "--json" && i + 1 < argc) {
            json_path = argv[++i];
        } else {
            std::fprintf(stderr,
                         "usage: bench_points [--quick | --smoke] [--registration-only] "
                         "[--json FILE]\n");
            return 2;
        }
    }
    if (std::string(s.name) == kSmoke.name) {
        peer.open3d_script.clear();  // the smoke run stays quick and self-contained
        peer.server.clear();
    } else {
        if (std::system("/usr/bin/python3 -c 'import open3d' >/dev/null 2>&1") != 0) {
            std::printf("(python3-open3d is not installed: no Open3D peer in this run)\n");
            peer.open3d_script.clear();
        }
        if (!std::filesystem::exists(peer.server)) {
            std::printf("(%s is not built: no binary-endpoint rows in this run)\n",
                        peer.server.c_str());
            peer.server.clear();
        }
    }
    std::printf("bench_points (%s)\n", s.name);
    g_report["preset"] = s.name;
    g_report["points"] = nlohmann::json::array();
    // Written at the end of each way out, so that a run of its parts leaves what it measured.
    auto write_json = [&] {
        if (json_path.empty())
            return true;
        std::ofstream f(json_path);
        f << g_report.dump(1) << "\n";
        if (!f) {
            std::fprintf(stderr, "bench_points: cannot write %s\n", json_path.c_str());
            return false;
        }
        return true;
    };
    registration(s);
    if (registration_only)
        return write_json() ? 0 : 1;
    const double worst = points_on_a(s, peer);
    points_on_b(s, peer);
    winding_on_b(s);
    // The icosphere of level l is within about (π/(5·2^l))²/2 of the unit sphere.
    const double tolerance = 0.5 * std::pow(M_PI / (5.0 * std::pow(2.0, s.ico_level)), 2) * 4;
    std::printf("signed distance vs the unit sphere: worst %.2e (the icosphere is within %.2e)\n",
                worst, tolerance);
    g_report["sphere_check"] = {{"worst", worst}, {"tolerance", tolerance}};
    const bool written = write_json();
    return worst <= tolerance && written ? 0 : 1;
}
