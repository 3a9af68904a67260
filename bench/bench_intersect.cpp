// bench_intersect: raycastd's engine called in-process against raw Embree (the ceiling), on the
// same workloads and the same rays in the same run. Prints one line per measurement and, with
// --json, writes every figure for bench/run_all.py; with --data-dir it also writes the meshes,
// rays and raw Embree's hits that the out-of-process peers (HTTP, Open3D) are run on.
//
//   bench_intersect                 full size: A 81,920 / B 1,024,000 triangles, C 1000 spheres,
//                                   1M coherent + 1M incoherent rays each
//   bench_intersect --quick         small sizes (seconds)
//   bench_intersect --smoke         tiny sizes, < 1 s; exits 1 if the engine disagrees with
//                                   Embree (this is the CTest `bench_smoke`)
//   bench_intersect --memory-probe W   one JSON line: the resident bytes the engine keeps for
//                                   workload W after a refined and an exact query (run by the
//                                   others, a process of its own for each mesh workload)
//   bench_intersect --memory-probe-trimmed W   the same with the heap freed so far given back
//                                   (malloc_trim) before the first reading and the last
//   options: --threads N  --budget SECONDS  --workloads ABC  --data-dir DIR  --json FILE
//            --raw-only (raw Embree's builds and traces alone, no engine)
//            --ceiling-only (raw rtcIntersect1 alone: run_all.py times it around each peer)
//            --modes closest,any,...  --precisions fast,refined,...  (engine rows measured)

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "bench/bench_files.h"
#include "bench/raw_embree.h"
#include "bench/timing.h"
#include "bench/workloads.h"
#include "engine/huge_pages.h"
#include "engine/process_memory.h"
#include "engine/query/intersect.h"

namespace rb = raycastd::bench;
namespace re = raycastd::engine;
using nlohmann::json;

namespace {

/// The sizes of one preset: its workloads' and ray sets' (rb::WorkloadSizes), and its timing.
struct Sizes : rb::WorkloadSizes {
    const char* name;
    double budget_s;  ///< per engine measurement
    int reps;         ///< timed repetitions of each raw Embree measurement
};

constexpr Sizes kFull{rb::kFullSizes, "full", 1.5, 5};
constexpr Sizes kQuick{rb::kQuickSizes, "quick", 0.3, 3};
constexpr Sizes kSmoke{rb::kSmokeSizes, "smoke", 0.02, 1};

constexpr std::uint32_t kMiss = 0xFFFFFFFFu;
/// The smoke test fails below this agreement with Embree. Not 1: Embree's single-precision test
/// and the engine may legitimately disagree on rays that graze an edge or a silhouette.
constexpr double kMinAgreement = 0.99;

struct Args {
    Sizes sizes = kFull;
    int threads = static_cast<int>(std::thread::hardware_concurrency());
    double budget_s = -1.0;  ///< < 0: the preset's
    std::string workloads = "ABC";
    std::string data_dir;
    std::string json_path;
    bool raw_only = false;                          ///< raw Embree alone, no engine
    bool ceiling_only = false;                      ///< raw rtcIntersect1 alone, no files
    std::string modes = "closest,any,all,count";    ///< engine modes measured
    std::string precisions = "fast,refined,exact";  ///< engine precisions measured
    char memory_probe = 0;                          ///< --memory-probe W: that probe alone
    bool memory_trimmed = false;                    ///< --memory-probe-trimmed W: trimmed
    std::string self;                               ///< argv[0], to run the probe
};

bool parse_args(int argc, char** argv, Args& a) {
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        auto value = [&]() -> std::string { return i + 1 < argc ? argv[++i] : ""; };
        if (arg == "--smoke") {
            a.sizes = kSmoke;
        } else if (arg == "--quick") {
            a.sizes = kQuick;
        } else if (arg == "--threads") {
            a.threads = std::atoi(value().c_str());
        } else if (arg == "--budget") {
            a.budget_s = std::atof(value().c_str());
        } else if (arg == "--workloads") {
            a.workloads = value();
        } else if (arg == "--data-dir") {
            a.data_dir = value();
        } else if (arg == "--ceiling-only") {
            a.ceiling_only = true;
        } else if (arg == "--raw-only") {
            a.raw_only = true;
        } else if (arg == "--json") {
            a.json_path = value();
        } else if (arg == "--memory-probe" || arg == "--memory-probe-trimmed") {
            const std::string w = value();
            if (w != "A" && w != "B" && w != "C") {
                std::fprintf(stderr, "bench_intersect: %s takes A, B or C\n", arg.c_str());
                return false;
            }
            a.memory_probe = w[0];
            a.memory_trimmed = arg == "--memory-probe-trimmed";
        } else if (arg == "--modes") {
            a.modes = value();
        } else if (arg == "--precisions") {
            a.precisions = value();
        } else {
            std::fprintf(stderr, "bench_intersect: unknown argument %s\n", arg.c_str());
            return false;
        }
    }
    if (a.budget_s < 0.0)
        a.budget_s = a.sizes.budget_s;
    return a.threads > 0;
}

/// Collects the measurements, printing each as it arrives.
class Report {
  public:
    void trace(const std::string& workload, const std::string& rays, const std::string& peer,
               const std::string& variant, const std::string& mode, const std::string& precision,
               const rb::BudgetedTiming& t, json extra) {
        json row = {
            {"kind", "trace"},        {"workload", workload},       {"rays", rays},
            {"peer", peer},           {"variant", variant},         {"mode", mode},
            {"precision", precision}, {"mrays_s", t.mrays_per_s()}, {"measured_rays", t.rays},
            {"total_rays", t.total},  {"sampled", t.sampled()}};
        row.update(extra);
        if (peer == "raw_embree" && variant == "rtcIntersect1")
            ceiling_[workload + rays] = t.mrays_per_s();
        // Engine rows carry the ceiling re-timed around them (see bench_engine).
        const double ceiling = row.contains("paired_ceiling_mrays_s")
                                   ? row["paired_ceiling_mrays_s"].get<double>()
                                   : ceiling_.value(workload + rays, 0.0);
        std::printf("%-2s %-10s %-10s %-29s %-7s %-7s %9.3f Mrays/s  %5.2fx%s\n", workload.c_str(),
                    rays.c_str(), peer.c_str(), variant.c_str(), mode.c_str(), precision.c_str(),
                    t.mrays_per_s(), ceiling > 0 ? t.mrays_per_s() / ceiling : 0.0,
                    t.sampled() ? ("  (sample of " + std::to_string(t.rays) + ")").c_str() : "");
        std::fflush(stdout);
        rows_.push_back(std::move(row));
    }
    void build(const std::string& workload, const std::string& peer, const std::string& variant,
               double ms) {
        std::printf("%-2s %-10s %-10s %-30s %20.1f ms\n", workload.c_str(), "build", peer.c_str(),
                    variant.c_str(), ms);
        rows_.push_back({{"kind", "build"},
                         {"workload", workload},
                         {"peer", peer},
                         {"variant", variant},
                         {"ms", ms}});
    }
    void memory(const json& probe) {
        const double tris = probe.value("triangles", 0.0);
        if (!(tris > 0))
            return;
        const double after = probe.value("resident_refined_exact", 0.0);
        const double held = probe.value("held_refined_exact", 0.0);
        char held_text[64] = "";
        if (held > 0)  // the trimmed probe ran (glibc)
            std::snprintf(held_text, sizeof held_text, "; with the freed heap given back %.0f B",
                          held / tris);
        std::printf(
            "%-2s %-10s resident after refined and exact queries %.1f MB: %.0f B a triangle "
            "(after the build alone %.0f B%s; the engine's own estimate %.0f B)\n",
            probe.value("workload", "").c_str(), "memory", after / 1e6, after / tris,
            probe.value("resident_after_build", 0.0) / tris, held_text,
            probe.value("engine_estimate", 0.0) / tris);
        json row = probe;
        row["kind"] = "memory";
        rows_.push_back(std::move(row));
    }
    json& meta() { return meta_; }
    bool write(const std::string& path) const {
        std::ofstream out(path);
        out << json{{"meta", meta_}, {"rows", rows_}}.dump(1) << "\n";
        return static_cast<bool>(out);
    }

  private:
    json meta_ = json::object();
    json rows_ = json::array();
    json ceiling_ = json::object();
};

/// Fraction of the sampled rays on which the engine's closest hit matches Embree's: same
/// hit/miss, and the same primitive or (a neighbour across a shared edge) the same t.
double closest_agreement(const re::QueryResult& r, const std::vector<std::size_t>& idx,
                         const rb::RawHits& ref) {
    std::size_t agree = 0;
    for (std::size_t k = 0; k < idx.size(); ++k) {
        const re::Hit& h = r.hits[k];
        const std::size_t i = idx[k];
        const bool ref_hit = ref.object[i] != kMiss;
        if (h.valid() != ref_hit)
            continue;
        if (!ref_hit || (h.object == ref.object[i] && h.primitive == ref.primitive[i]) ||
            std::abs(h.t - ref.t[i]) <= 1e-4 * std::max(1.0, std::abs(h.t))) {
            ++agree;
        }
    }
    return idx.empty() ? 1.0 : static_cast<double>(agree) / idx.size();
}

double any_agreement(const re::QueryResult& r, const std::vector<std::size_t>& idx,
                     const std::vector<std::uint8_t>& ref) {
    std::size_t agree = 0;
    for (std::size_t k = 0; k < idx.size(); ++k)
        agree += r.hits[k].valid() == (ref[idx[k]] != 0);
    return idx.empty() ? 1.0 : static_cast<double>(agree) / idx.size();
}

/// Hits per ray in the engine's answer (for `all`/`count`: crossings per ray).
double hits_per_ray(const re::QueryResult& r, re::Mode mode, std::size_t n) {
    if (n == 0)
        return 0.0;
    double hits = 0;
    if (mode == re::Mode::count) {
        for (auto c : r.counts)
            hits += c;
    } else if (mode == re::Mode::all) {
        hits = r.offsets.empty() ? 0.0 : r.offsets.back();
    } else {
        for (const auto& h : r.hits)
            hits += h.valid();
    }
    return hits / static_cast<double>(n);
}

struct RaySetRefs {
    rb::RawHits closest;
    std::vector<std::uint8_t> occluded;
};

/// Raw Embree on one ray set: the four call kinds, plus rtcIntersect1 on a ROBUST scene.
RaySetRefs bench_raw(Report& report, const rb::Workload& w, const std::string& rays_name,
                     const std::vector<rb::RayRecord>& rays, const rb::RawEmbree& embree,
                     const rb::RawEmbree& robust, int reps) {
    const bool coherent = rays_name == "coherent";
    const std::size_t n = rays.size();
    RaySetRefs refs;
    refs.closest.prepare(n);
    refs.occluded.assign(n, 0);
    auto timing = [&](double s) { return rb::BudgetedTiming{s, n, n}; };
    auto row = [&](const char* variant, const char* mode, double s, double hit_fraction) {
        report.trace(w.name, rays_name, "raw_embree", variant, mode, "fast", timing(s),
                     {{"hits_per_ray", hit_fraction}});
    };
    double s = rb::median_seconds(reps, [&] { embree.intersect1(rays, refs.closest); });
    row("rtcIntersect1", "closest", s, double(refs.closest.hit_count()) / n);
    rb::RawHits packets;
    packets.prepare(n);
    s = rb::median_seconds(reps, [&] { embree.intersect16(rays, coherent, packets); });
    row("rtcIntersect16", "closest", s, double(packets.hit_count()) / n);
    s = rb::median_seconds(reps, [&] { embree.occluded1(rays, refs.occluded); });
    auto occluded_fraction = [&](const std::vector<std::uint8_t>& o) {
        std::size_t c = 0;
        for (auto x : o)
            c += x;
        return double(c) / n;
    };
    row("rtcOccluded1", "any", s, occluded_fraction(refs.occluded));
    std::vector<std::uint8_t> occluded16(n, 0);
    s = rb::median_seconds(reps, [&] { embree.occluded16(rays, coherent, occluded16); });
    row("rtcOccluded16", "any", s, occluded_fraction(occluded16));
    rb::RawHits robust_hits;
    robust_hits.prepare(n);
    s = rb::median_seconds(reps, [&] { robust.intersect1(rays, robust_hits); });
    row("rtcIntersect1 ROBUST", "closest", s, double(robust_hits.hit_count()) / n);
    return refs;
}

/// Written with every allocation bench_result_allocation times, so that it cannot be elided.
const void* volatile g_escape = nullptr;

/// What a fresh answer costs before any tracing: QueryResult::hits is a new std::vector<Hit>
/// of one Hit per ray, and the first touch of fresh pages is ~2.5 ms per MB on this machine
/// (less on huge pages, which the engine asks for on answers of 32 MiB and more).
/// Reported so that the engine's figures can be read against this floor.
void bench_result_allocation(Report& report, const rb::Workload& w, const std::string& rays_name,
                             std::size_t n, int reps) {
    const double s = rb::median_seconds(reps, [&] {
        std::vector<re::Hit> hits;
        re::reserve_fresh(hits, n);  // as QueryEngine::intersect grows a fresh answer
        hits.resize(n);
        g_escape = hits.data();
    });
    report.trace(w.name, rays_name, "overhead", "fresh std::vector<Hit>", "closest", "-",
                 rb::BudgetedTiming{s, n, n}, {{"bytes", n * sizeof(re::Hit)}});
}

/// Whether `name` is one of the comma-separated `list`.
bool listed(const std::string& list, const std::string& name) {
    return ("," + list + ",").find("," + name + ",") != std::string::npos;
}

/// The engine in-process on the ceiling's own input and output: float ray records in, the
/// hit's t, object and primitive out (RawHits), through QueryEngine::intersect_blocks, as the
/// server's binary path calls it. No 64-byte rays or 72-byte hits for the whole batch: measured
/// 10-20% faster than QueryEngine::intersect on 1M rays.
template <class Ceiling>
void bench_records(Report& report, const rb::Workload& w, const std::string& rays_name,
                   const std::vector<rb::RayRecord>& rays, const re::QueryEngine& engine,
                   re::QueryOptions opt, double budget_s, Ceiling&& ceiling_mrays_s) {
    opt.want_normal = false;  // as raw Embree's rows: t, object and primitive
    rb::RawHits out;
    out.prepare(rays.size());
    std::vector<rb::RayRecord> sample;
    const re::QueryEngine::BlockSink sink = [&](std::size_t b, std::size_t e, const re::Hit* h) {
        for (std::size_t i = b; i < e; ++i, ++h) {
            out.t[i] = static_cast<float>(h->t);
            out.object[i] = h->object;
            out.primitive[i] = h->primitive;
        }
    };
    const double ceiling_before = ceiling_mrays_s();
    const auto t = rb::budgeted_seconds(rays.size(), budget_s, [&](std::size_t n) {
        if (n < rays.size() && sample.size() != n) {
            sample.clear();
            for (std::size_t i : rb::strided_sample(rays.size(), n))
                sample.push_back(rays[i]);
        }
        const rb::RayRecord* in = n < rays.size() ? sample.data() : rays.data();
        const re::QueryEngine::BlockSource source = [&](std::size_t b, std::size_t e, re::Ray* r) {
            for (std::size_t i = b; i < e; ++i, ++r) {
                const rb::RayRecord& x = in[i];
                *r = re::Ray{{x.ox, x.oy, x.oz}, {x.dx, x.dy, x.dz}, x.tmin, x.tmax};
            }
            return true;
        };
        return rb::seconds([&] { engine.intersect_blocks(n, opt, source, sink); });
    });
    json extra = {{"paired_ceiling_mrays_s", 0.5 * (ceiling_before + ceiling_mrays_s())}};
    report.trace(w.name, rays_name, "engine", "QueryEngine::intersect_blocks",
                 re::to_string(opt.mode), re::to_string(opt.precision), t, extra);
}

/// The engine in-process on one ray set: every mode at every precision, time-budgeted.
/// Returns the lowest agreement with Embree seen (closest and any).
double bench_engine(Report& report, const rb::Workload& w, const std::string& rays_name,
                    const std::vector<rb::RayRecord>& rays, const re::QueryEngine& engine,
                    const rb::RawEmbree& embree, const RaySetRefs& refs, double budget_s,
                    const std::string& modes, const std::string& precisions) {
    const std::vector<re::Ray> all = rb::to_engine_rays(rays);
    // The ceiling again, right before and right after each engine measurement: on a shared
    // machine the load drifts within seconds, and a ratio of figures taken under the same load
    // is steadier than a ratio to the ceiling measured once at the start.
    rb::RawHits scratch;
    scratch.prepare(rays.size());
    auto ceiling_mrays_s = [&] {
        const double s = rb::seconds([&] { embree.intersect1(rays, scratch); });
        return s > 0.0 ? rays.size() / s * 1e-6 : 0.0;
    };
    double worst = 1.0;
    for (re::Mode mode : {re::Mode::closest, re::Mode::any, re::Mode::all, re::Mode::count}) {
        for (re::Precision p :
             {re::Precision::fast, re::Precision::refined, re::Precision::exact}) {
            if (!listed(modes, re::to_string(mode)) || !listed(precisions, re::to_string(p)))
                continue;
            const re::QueryOptions opt{mode, p, /*want_normal=*/true};
            std::vector<re::Ray> sample;
            std::vector<std::size_t> idx;
            re::QueryResult last;
            // Touch the answer's pages for the whole set before timing: the sample grows from 64
            // rays, and a run that first grows the buffers pays their page faults (~180 ms for
            // 72 MB of hits, measured as a sporadic 3x drop on B).
            last.hits.resize(2 * all.size());
            last.hits.clear();
            last.offsets.resize(all.size() + 1);
            last.offsets.clear();
            last.counts.resize(all.size());
            last.counts.clear();
            const double ceiling_before = ceiling_mrays_s();
            const auto t = rb::budgeted_seconds(all.size(), budget_s, [&](std::size_t n) {
                if (idx.size() != n) {
                    idx = rb::strided_sample(all.size(), n);
                    sample.clear();
                    if (n < all.size()) {
                        for (std::size_t i : idx)
                            sample.push_back(all[i]);
                    }
                }
                const std::vector<re::Ray>& input = n < all.size() ? sample : all;
                // The answer's buffers are reused from run to run, as the server reuses one per
                // worker thread (and as raw Embree reuses its scratch): fresh pages cost
                // ~2.5 ms/MB here, more than the tracing (see the "fresh std::vector" row).
                return rb::seconds([&] { engine.intersect(input, opt, last); });
            });
            json extra = {{"answered_precision", re::to_string(last.precision)},
                          {"hits_per_ray", hits_per_ray(last, mode, t.rays)}};
            if (mode == re::Mode::closest || mode == re::Mode::any) {
                const double agree = mode == re::Mode::closest
                                         ? closest_agreement(last, idx, refs.closest)
                                         : any_agreement(last, idx, refs.occluded);
                extra["agree_with_embree"] = agree;
                worst = std::min(worst, agree);
            }
            extra["paired_ceiling_mrays_s"] = 0.5 * (ceiling_before + ceiling_mrays_s());
            report.trace(w.name, rays_name, "engine", "QueryEngine::intersect", re::to_string(mode),
                         re::to_string(p), t, extra);
            if (mode == re::Mode::closest || mode == re::Mode::any)
                bench_records(report, w, rays_name, rays, engine, opt, budget_s, ceiling_mrays_s);
        }
    }
    return worst;
}

bool write_workload_files(const std::string& dir, const rb::Workload& w) {
    const std::string stem = dir + "/" + w.name;
    if (!w.spheres.empty())
        return rb::write_sphere_scene(stem + "_scene.json", w);
    return rb::write_ply(stem + ".ply", w) && rb::write_mesh_arrays(stem, w);
}

/// --ceiling-only: raw rtcIntersect1 on both ray sets and nothing else, so that run_all.py can
/// time the ceiling right before and right after an out-of-process peer (HTTP, Open3D).
bool bench_ceiling_only(Report& report, const rb::Workload& w, const Args& args) {
    std::string error;
    auto embree = rb::RawEmbree::build(w, rb::BuildQuality::medium, /*robust=*/false, error);
    if (!embree) {
        std::fprintf(stderr, "bench_intersect: %s\n", error.c_str());
        return false;
    }
    report.meta()["workloads"][w.name] = {{"description", w.description}};
    for (const std::string rays_name : {"coherent", "incoherent"}) {
        const auto rays = rb::ray_set(w, rays_name == "coherent", args.sizes);
        rb::RawHits hits;
        hits.prepare(rays.size());
        const double s = rb::median_seconds(3, [&] { embree->intersect1(rays, hits); });
        report.trace(w.name, rays_name, "raw_embree", "rtcIntersect1", "closest", "fast",
                     rb::BudgetedTiming{s, rays.size(), rays.size()}, json::object());
    }
    return true;
}

void bench_memory(Report& report, const std::string& self, const Sizes& sizes, char name);

/// Everything for one workload. Returns false on an error that makes its figures meaningless.
bool bench_workload(Report& report, const rb::Workload& w, const Args& args, double& worst) {
    const Sizes& s = args.sizes;
    json& meta = report.meta()["workloads"][w.name];
    meta = {{"description", w.description},
            {"triangles", w.triangles.size()},
            {"spheres", w.spheres.size()}};
    if (!args.data_dir.empty() && !write_workload_files(args.data_dir, w)) {
        std::fprintf(stderr, "bench_intersect: cannot write %s's files to %s\n", w.name.c_str(),
                     args.data_dir.c_str());
        return false;
    }

    std::string error;
    // The first build in the process also starts TBB's and Embree's threads: keep it untimed.
    rb::RawEmbree::build(w, rb::BuildQuality::low, /*robust=*/false, error);
    for (auto q : {rb::BuildQuality::low, rb::BuildQuality::high}) {
        auto e = rb::RawEmbree::build(w, q, /*robust=*/false, error);
        if (!e)
            break;
        report.build(w.name, "raw_embree", std::string("rtcCommitScene ") + to_string(q),
                     e->build_ms());
    }
    auto embree = rb::RawEmbree::build(w, rb::BuildQuality::medium, /*robust=*/false, error);
    auto robust = embree ? rb::RawEmbree::build(w, rb::BuildQuality::medium, true, error) : nullptr;
    if (!embree || !robust) {
        std::fprintf(stderr, "bench_intersect: %s\n", error.c_str());
        return false;
    }
    report.build(w.name, "raw_embree", "rtcCommitScene medium", embree->build_ms());
    report.build(w.name, "raw_embree", "rtcCommitScene medium ROBUST", robust->build_ms());

    std::shared_ptr<const re::QueryEngine> engine;
    if (!args.raw_only) {
        auto scene = std::make_shared<const re::Scene>(rb::to_engine_scene(w));
        re::Result<std::shared_ptr<const re::QueryEngine>> built =
            re::Status::error(re::Code::internal, "not built");
        const double build_s =
            rb::median_seconds(s.reps > 1 ? 3 : 1, [&] { built = re::QueryEngine::build(scene); });
        if (!built.ok()) {
            std::fprintf(stderr, "bench_intersect: QueryEngine::build: %s\n",
                         built.status().message.c_str());
            return false;
        }
        report.build(w.name, "engine", "QueryEngine::build", 1e3 * build_s);
        engine = *built;
        // The exact BVH is built on the first query that needs it (exact, and refined's
        // confirmation of a float miss). Built here, untimed by the traces, and reported apart.
        const auto bs = w.bounding_sphere();
        const re::Ray probe{{bs[0], bs[1], bs[2]}, {0.0, 0.0, 1.0}};
        const double lazy_s = rb::seconds([&] {
            engine->intersect({probe}, re::QueryOptions{re::Mode::closest, re::Precision::exact});
        });
        report.build(w.name, "engine", "exact BVH (built by the first exact query)", 1e3 * lazy_s);
        // So is fast's non-robust BVH (docs/numerics.md), on the first fast query.
        const double fast_s = rb::seconds([&] {
            engine->intersect({probe}, re::QueryOptions{re::Mode::closest, re::Precision::fast});
        });
        report.build(w.name, "engine", "fast BVH (built by the first fast query)", 1e3 * fast_s);
        // Resident memory, in a process of its own (this one holds raw Embree's scenes and the
        // timed builds' freed pages).
        if (w.triangles.size() > 0)
            bench_memory(report, args.self, args.sizes, w.name[0]);
    }

    for (const std::string rays_name : {"coherent", "incoherent"}) {
        const auto rays = rb::ray_set(w, rays_name == "coherent", s);
        meta["rays"][rays_name] = rays.size();
        const RaySetRefs refs = bench_raw(report, w, rays_name, rays, *embree, *robust, s.reps);
        if (!args.data_dir.empty()) {
            const std::string stem = args.data_dir + "/" + w.name + "_" + rays_name;
            if (!rb::write_rays(stem + "_rays.npy", rays) ||
                !rb::write_hits(stem + "_ref", refs.closest)) {
                std::fprintf(stderr, "bench_intersect: cannot write %s\n", stem.c_str());
                return false;
            }
        }
        if (engine) {
            bench_result_allocation(report, w, rays_name, rays.size(), s.reps);
            worst = std::min(worst, bench_engine(report, w, rays_name, rays, *engine, *embree, refs,
                                                 args.budget_s, args.modes, args.precisions));
        }
    }
    return true;
}

/// Gives the heap's free pages back to the system (glibc's malloc_trim); false elsewhere.
bool trim_heap() {
#if defined(__GLIBC__)
    malloc_trim(0);
    return true;
#else
    return false;
#endif
}

/// --memory-probe W (run as a process of its own, from bench_workload): what the engine keeps
/// resident for workload W once it has answered a refined and an exact query (issue 17: the
/// native BVH with its widened triangles, the exact BVH, the scene's own vertices and indices),
/// as one JSON line. A small scene is built and queried first, so that Embree's device, TBB's
/// threads and the allocator's first arenas are not counted.
int memory_probe(char name, const Sizes& sizes, bool trimmed) {
    const rb::Workload warm = rb::make_workload('A', kSmoke);
    const re::Ray probe{{0.0, 0.0, -10.0}, {0.0, 0.0, 1.0}};
    for (re::Precision p : {re::Precision::refined, re::Precision::exact}) {
        auto e =
            re::QueryEngine::build(std::make_shared<const re::Scene>(rb::to_engine_scene(warm)));
        if (e.ok())
            (*e)->intersect({probe}, re::QueryOptions{re::Mode::closest, p});
    }
    const rb::Workload w = rb::make_workload(name, sizes);
    const auto bs = w.bounding_sphere();
    const re::Ray ray{{bs[0], bs[1], bs[2] - 2.0 * bs[3]}, {0.0, 0.0, 1.0}};
    // `trimmed` (--memory-probe-trimmed): the heap freed so far given back before the first
    // reading and the last (not the one after the build), so that the growth is what the engine
    // holds, not the heap its build freed and glibc kept
    // for later allocations (its mmap threshold rises with each large block freed:
    // docs/numerics.md, the memory of a scene). The row itself is the process as it is.
    if (trimmed && !trim_heap())
        return 1;
    const std::size_t before = re::process_resident_bytes();
    auto built = re::QueryEngine::build(std::make_shared<const re::Scene>(rb::to_engine_scene(w)));
    if (!built.ok())
        return 1;
    const auto& engine = *built;
    const std::size_t after_build = re::process_resident_bytes();
    engine->intersect({ray}, re::QueryOptions{re::Mode::closest, re::Precision::refined});
    engine->intersect({ray}, re::QueryOptions{re::Mode::closest, re::Precision::exact});
    if (trimmed)
        trim_heap();
    const std::size_t after = re::process_resident_bytes();
    std::printf("%s\n", json{{"workload", w.name},
                             {"trimmed", trimmed},
                             {"triangles", engine->scene().triangle_count()},
                             {"resident_after_build", after_build - before},
                             {"resident_refined_exact", after - before},
                             {"engine_estimate", engine->memory_bytes()}}
                            .dump()
                            .c_str());
    return 0;
}

/// Runs this binary's --memory-probe for workload `name` and reports its figures.
void bench_memory(Report& report, const std::string& self, const Sizes& sizes, char name) {
    const std::string flag = sizes.name == std::string(kQuick.name)   ? " --quick"
                             : sizes.name == std::string(kSmoke.name) ? " --smoke"
                                                                      : "";
    json j = json::parse(rb::command_output(self + flag + " --memory-probe " + name), nullptr,
                         /*allow_exceptions=*/false);
    if (!j.is_object())
        return;
    // The same in a process of its own with the freed heap given back before each reading.
    const json t =
        json::parse(rb::command_output(self + flag + " --memory-probe-trimmed " + name), nullptr,
                    /*allow_exceptions=*/false);
    if (t.is_object() && t.value("trimmed", false))
        j["held_refined_exact"] = t.value("resident_refined_exact", 0.0);
    report.memory(j);
}

std::string utc_now() {
    const std::time_t now = std::time(nullptr);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    return buf;
}

}  // namespace

int main(int argc, char** argv) {
    Args args;
    if (!parse_args(argc, argv, args))
        return 2;
    args.self = argv[0];
    if (args.memory_probe)
        return memory_probe(args.memory_probe, args.sizes, args.memory_trimmed);
    // Every TBB loop in the process (ours, the engine's, Embree's BVH build) uses this many
    // threads.
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                static_cast<std::size_t>(args.threads));
    const auto wall_start = std::chrono::steady_clock::now();
    const std::clock_t cpu_start = std::clock();
    Report report;
    report.meta() = {{"preset", args.sizes.name},          {"threads", args.threads},
                     {"embree", rb::RawEmbree::version()}, {"date", utc_now()},
                     {"budget_s", args.budget_s},          {"workloads", json::object()}};
    std::printf("bench_intersect: preset %s, %d threads, Embree %s\n", args.sizes.name,
                args.threads, rb::RawEmbree::version().c_str());
    double worst = 1.0;
    bool ok = true;
    for (char name : args.workloads) {
        const rb::Workload w = rb::make_workload(name, args.sizes);
        std::printf("-- %s: %s\n", w.name.c_str(), w.description.c_str());
        ok = (args.ceiling_only ? bench_ceiling_only(report, w, args)
                                : bench_workload(report, w, args, worst)) &&
             ok;
    }
    report.meta()["worst_agreement"] = worst;
    // CPU time of all our threads over wall time: how much of the machine this run really had
    // (2.0 on an idle 2-core machine; far less while others compile).
    const double wall_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    const double cpu_s = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
    report.meta()["cores_used"] = wall_s > 0.0 ? cpu_s / wall_s : 0.0;
    std::printf("cores used on average (CPU time / wall time): %.2f of %d\n",
                wall_s > 0.0 ? cpu_s / wall_s : 0.0, args.threads);
    if (!args.json_path.empty() && !report.write(args.json_path)) {
        std::fprintf(stderr, "bench_intersect: cannot write %s\n", args.json_path.c_str());
        ok = false;
    }
    std::printf("worst agreement of the engine with Embree (closest, any): %.4f\n", worst);
    if (worst < kMinAgreement) {
        std::fprintf(stderr,
                     "bench_intersect: the engine disagrees with Embree on %.2f%% of rays\n",
                     100.0 * (1.0 - worst));
        ok = false;
    }
    return ok ? 0 : 1;
}
