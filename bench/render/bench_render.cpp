// Render benchmark (issue 5): raycastd's Whitted renderer against POV-Ray on the same scenes,
// in the same run, at 1024×768, spp 1 and 4, max_depth 5:
//   (a) tests/golden/scenes/tutorial_like.json: spheres with a glass and a mirror one, a floor,
//       two point lights;
//   (b) tests/golden/scenes/duck.json: the glTF sample Duck on a reflective floor.
// POV-Ray renders a .pov written from the same scene document (pov_writer.h) with 2 threads;
// spp 4 maps to POV-Ray's antialiasing method 1 (+AM1 +A0.0 +R2: 2×2 extra samples in every
// pixel whose colour differs at all from a neighbour's, so POV-Ray supersamples only where the
// image is not flat). raycastd's rows at spp 4 are uniform (4 samples in every pixel, its
// default) and adaptive ("sampling": "adaptive": 3 more samples in every pixel whose first
// sample shows differently in 8 bits from a neighbour's), the same policy as POV-Ray's. Also
// reported: the renderer's rays per second against raw Embree tracing the Duck scene's primary rays
// (bench/raw_embree.h), the ceiling for rays.
//
// Each row's time is the median of --runs runs (1 by default; the figures in docs/ are of
// --runs 3), POV-Ray's too (since 2026-12-05; before, POV-Ray ran once per scene and spp). Since
// 2026-12-07 the runs are interleaved: run k of POV-Ray, then run k of every raycastd variant of
// that scene and spp, so that both medians come from the same minutes of a shared host.
//   bench_render [--runs N] [--povray PATH|none] [--out FILE] [--smoke] [--write-pov DIR]
//                [--scenes tutorial_like,duck] [--precisions refined,fast] [--single-rays]
//                [--size WxH]
// --write-pov writes each scene's .pov (1024×768, or --size's) into DIR and renders nothing.
// --single-rays adds rows with every ray traced one at a time (no batches, no packets).
// --size renders at W×H instead of 1024×768 (--smoke: 128×96): a small render of the Duck for
// callgrind, whose instruction counts are deterministic where this shared host's times are not.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "bench/raw_embree.h"
#include "bench/render/pov_writer.h"
#include "engine/render/camera_rays.h"
#include "engine/render/image.h"
#include "engine/render/render.h"
#include "server/model_source.h"

namespace {

using namespace raycastd;
using Clock = std::chrono::steady_clock;

struct Args {
    int runs = 1;
    std::string povray = "povray";
    std::string out;
    bool smoke = false;
    std::string write_pov;
    std::string scenes = "tutorial_like,duck";  ///< which scenes to render
    std::string precisions = "refined,fast";    ///< at which precisions
    /// Also render each case with every ray traced one at a time (the renderer before rays
    /// were traced generation by generation in packets), to measure what the batching gives.
    bool single_rays = false;
    int width = 0, height = 0;  ///< --size (0: 1024×768, or --smoke's 128×96)
};

std::string read_file(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

std::shared_ptr<const engine::QueryEngine> load_scene(const std::string& name) {
    const std::string data = RAYCASTD_SHARED_DIR "/data";
    const server::FileSource files = [&](const std::string& path) -> engine::Result<std::string> {
        std::ifstream f(data + "/" + path, std::ios::binary);
        if (!f)
            return engine::Status::error(engine::Code::not_found, "cannot read " + path);
        return read_file(data + "/" + path);
    };
    const auto doc = server::Json::parse(
        read_file(std::string(RAYCASTD_SOURCE_DIR "/tests/golden/scenes/") + name + ".json"));
    auto scene = server::scene_from_document(doc, "", files, server::Limits{});
    auto built = engine::QueryEngine::build(std::make_shared<engine::Scene>(std::move(scene)));
    if (!built.ok())
        throw std::runtime_error(built.status().message);
    return *built;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

/// Milliseconds of POV-Ray rendering `pov` (wall clock, parse and bounding included), or −1.
double run_povray(const Args& a, const std::string& pov, int w, int h, int spp) {
    const std::string dir = "/tmp/raycastd_bench_render";
    std::system(("mkdir -p " + dir).c_str());
    std::ofstream(dir + "/scene.pov") << pov;
    const std::string aa = spp > 1 ? " +A0.0 +AM1 +R2" : " -A";
    const std::string cmd = a.povray + " +I" + dir + "/scene.pov +O" + dir + "/scene.png +W" +
                            std::to_string(w) + " +H" + std::to_string(h) + aa + " -D +WT2 +FN > " +
                            dir + "/povray.log 2>&1";
    const auto t0 = Clock::now();
    const int rc = std::system(cmd.c_str());
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    return rc == 0 ? ms : -1.0;
}

/// Raw Embree (rtcIntersect1 and rtcIntersect16) on the primary rays of a triangle-only scene.
std::pair<double, double> raw_embree_mrays(const engine::Scene& s, const engine::Camera& cam, int w,
                                           int h) {
    bench::Workload wl;
    wl.name = "render";
    for (const auto& o : s.objects) {
        if (o.kind == engine::ObjectKind::sphere)
            return {-1, -1};
        const auto base = static_cast<std::uint32_t>(wl.positions.size());
        for (const auto& p : o.mesh->positions) {
            wl.positions.push_back(
                {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)});
        }
        for (const auto& t : o.mesh->triangles)
            wl.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    }
    const engine::CameraRays cr(cam, w, h);
    std::vector<bench::RayRecord> rays;
    for (int ty = 0; ty < h; ty += 4) {
        for (int tx = 0; tx < w; tx += 4) {
            for (int y = ty; y < ty + 4; ++y) {
                for (int x = tx; x < tx + 4; ++x) {
                    const engine::Ray r = cr.ray(x + 0.5, y + 0.5);
                    rays.push_back({float(r.origin.x), float(r.origin.y), float(r.origin.z),
                                    float(r.direction.x), float(r.direction.y),
                                    float(r.direction.z), 0.0f, bench::kRayTmax});
                }
            }
        }
    }
    std::string error;
    auto raw = bench::RawEmbree::build(wl, bench::BuildQuality::medium, /*robust=*/true, error);
    if (!raw)
        return {-1, -1};
    bench::RawHits hits;
    hits.prepare(rays.size());
    std::vector<double> t1, t16;
    for (int i = 0; i < 3; ++i) {
        auto t0 = Clock::now();
        raw->intersect1(rays, hits);
        t1.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
        t0 = Clock::now();
        raw->intersect16(rays, /*coherent=*/true, hits);
        t16.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    }
    return {rays.size() / median(t1) / 1e6, rays.size() / median(t16) / 1e6};
}

struct Row {
    std::string scene, precision;
    int spp;
    double ms, mrays, pov_ms;
    engine::RayCounts counts;
};

/// The Duck preview the bench timed, written beside --out as duck_preview.png (so that a
/// reader of the table can see what was rendered), and the PNG encode's time.
void write_preview(const Args& a, const engine::Image& image, std::ostringstream& extra) {
    const auto start = std::chrono::steady_clock::now();
    const std::string png = engine::encode_image(image, engine::ImageFormat::png, false);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    std::string path;
    if (!a.out.empty()) {
        const std::size_t slash = a.out.rfind('/');
        path = (slash == std::string::npos ? std::string() : a.out.substr(0, slash + 1)) +
               "duck_preview.png";
        std::ofstream(path, std::ios::binary) << png;
    }
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "Duck preview (spp 4, fast)%s%s: PNG encode %.1f ms, %zu bytes.\n",
                  path.empty() ? "" : " written to ", path.c_str(), ms, png.size());
    extra << buf;
}

}  // namespace

int main(int argc, char** argv) {
    Args a;
    for (int i = 1; i < argc; ++i) {
        const std::string s = argv[i];
        if (s == "--runs" && i + 1 < argc) {
            a.runs = std::max(1, std::atoi(argv[++i]));
        } else if (s == "--povray" && i + 1 < argc) {
            a.povray = argv[++i];
        } else if (s == "--out" && i + 1 < argc) {
            a.out = argv[++i];
        } else if (s == "--write-pov" && i + 1 < argc) {
            a.write_pov = argv[++i];
        } else if (s == "--smoke") {
            a.smoke = true;
        } else if (s == "--single-rays") {
            a.single_rays = true;
        } else if (s == "--scenes" && i + 1 < argc) {
            a.scenes = argv[++i];
        } else if (s == "--precisions" && i + 1 < argc) {
            a.precisions = argv[++i];
        } else if (s == "--size" && i + 1 < argc) {
            int used = 0;
            const char* size = argv[++i];
            if (std::sscanf(size, "%dx%d%n", &a.width, &a.height, &used) != 2 ||
                size[used] != '\0' || a.width < 1 || a.height < 1 || a.width > 8192 ||
                a.height > 8192) {
                std::cerr << "bench_render: --size takes WxH, each from 1 to 8192\n";
                return 2;
            }
        } else {
            std::cerr
                << "usage: bench_render [--runs N] [--povray PATH|none] [--out FILE] [--smoke]\n"
                   "                    [--scenes tutorial_like,duck] [--precisions "
                   "refined,fast] [--single-rays] [--size WxH]\n";
            return 2;
        }
    }
    // The Duck preview goes beside the table as duck_preview.png (write_preview): a table of
    // that name and the preview would overwrite each other (it happened: the table was left).
    if (!a.out.empty()) {
        const std::size_t slash = a.out.rfind('/');
        if (a.out.substr(slash == std::string::npos ? 0 : slash + 1) == "duck_preview.png") {
            std::cerr << "bench_render: --out names the table's file, and the Duck preview is "
                         "written beside it as duck_preview.png: give the table another name\n";
            return 2;
        }
    }
    const int w = a.width > 0 ? a.width : a.smoke ? 128 : 1024;
    const int h = a.height > 0 ? a.height : a.smoke ? 96 : 768;
    const std::vector<std::string> scenes = a.smoke
                                                ? std::vector<std::string>{"tutorial_like"}
                                                : std::vector<std::string>{"tutorial_like", "duck"};
    std::vector<Row> rows;
    std::ostringstream extra;
    const auto listed = [](const std::string& list, const std::string& name) {
        return ("," + list + ",").find("," + name + ",") != std::string::npos;
    };
    for (const std::string& name : scenes) {
        if (!listed(a.scenes, name))
            continue;
        std::shared_ptr<const engine::QueryEngine> engine;
        try {
            engine = load_scene(name);
        } catch (const std::exception& e) {
            std::cerr << "skipping " << name << ": " << e.what() << "\n";
            continue;
        }
        const engine::Camera cam = engine::resolve_camera(engine->scene(), std::nullopt, w, h);
        if (!a.write_pov.empty()) {
            std::ofstream(a.write_pov + "/" + name + ".pov")
                << bench::to_pov(engine->scene(), cam, w, h, 5);
            continue;
        }
        for (int spp : a.smoke ? std::vector<int>{1} : std::vector<int>{1, 4}) {
            // The variants of this scene and spp, each compared with the same POV-Ray figure
            // (fast is the render default, refined what intersect defaults to).
            struct Variant {
                engine::Precision p;
                bool batch, adaptive;
            };
            std::vector<Variant> variants;
            for (const Variant& v :
                 std::vector<Variant>{{engine::Precision::fast, true, false},
                                      {engine::Precision::fast, true, true},
                                      {engine::Precision::fast, false, false},
                                      {engine::Precision::refined, true, false},
                                      {engine::Precision::refined, true, true},
                                      {engine::Precision::refined, false, false}}) {
                if (!listed(a.precisions, engine::to_string(v.p)) || (!v.batch && !a.single_rays) ||
                    (v.adaptive && spp == 1))
                    continue;
                variants.push_back(v);
                if (a.smoke)
                    break;
            }
            const auto options = [&](const Variant& v) {
                engine::RenderOptions o;
                o.width = w;
                o.height = h;
                o.spp = spp;
                o.adaptive = v.adaptive;
                o.whitted.max_depth = 5;
                o.whitted.precision = v.p;
                o.whitted.trace_in_batches = v.batch;
                return o;
            };
            // Run by run, POV-Ray first and then every variant once, so that each renderer's
            // median is taken over the same minutes: the host's load moves by tens of percent
            // within minutes, and with POV-Ray's runs all before raycastd's the ratio had
            // moved with it (a quiet run put tutorial_like's spp 4 row at 6.5×, a busy moment
            // minutes later at 4.2×, with the same code: 2026-12-07).
            const bool with_povray = a.povray != "none" && !a.smoke;
            const std::string scene_pov =
                with_povray ? bench::to_pov(engine->scene(), cam, w, h, 5) : std::string();
            std::vector<double> pov_ms;
            std::vector<std::vector<double>> ms(variants.size());
            std::vector<engine::RenderResult> last(variants.size());
            // The Duck preview's variant keeps its image for write_preview; the others' images
            // (9 MB each at 1024×768) are dropped as soon as they are timed.
            const auto is_preview = [&](const Variant& v) {
                return name == "duck" && spp == 4 && v.p == engine::Precision::fast && v.batch &&
                       !v.adaptive;
            };
            for (int run = 0; run < a.runs; ++run) {
                // A POV-Ray that failed once is not run again: the row reports no figure.
                if (with_povray && std::count(pov_ms.begin(), pov_ms.end(), -1.0) == 0)
                    pov_ms.push_back(run_povray(a, scene_pov, w, h, spp));
                for (std::size_t k = 0; k < variants.size(); ++k) {
                    last[k] = engine::render(*engine, options(variants[k])).value();
                    ms[k].push_back(last[k].render_ms);
                    if (!is_preview(variants[k]))
                        last[k].image = engine::Image();
                }
            }
            // The median of --runs runs, POV-Ray's too (since 2026-12-05; before, POV-Ray ran
            // once per scene and spp, which had moved the ratio by a few percent between
            // otherwise equal runs of the bench); −1 if POV-Ray did not run or failed once.
            const double pov = pov_ms.empty() || std::count(pov_ms.begin(), pov_ms.end(), -1.0) > 0
                                   ? -1.0
                                   : median(pov_ms);
            for (std::size_t k = 0; k < variants.size(); ++k) {
                const Variant& v = variants[k];
                const engine::RenderResult& r = last[k];
                const double m = median(ms[k]);
                std::string precision = engine::to_string(r.precision);
                if (v.p == engine::Precision::fast && v.batch && !v.adaptive)
                    precision += " (default)";
                if (v.adaptive)
                    precision += ", adaptive";
                if (!v.batch)
                    precision += ", single rays";
                rows.push_back(
                    {name, precision, spp, m, r.counts.total() / m / 1e3, pov, r.counts});
                if (is_preview(v))
                    write_preview(a, r.image, extra);
            }
        }
        if (!a.smoke && name == "duck") {
            const auto [m1, m16] = raw_embree_mrays(engine->scene(), cam, w, h);
            extra << "Raw Embree on the Duck scene's " << w << "×" << h
                  << " primary rays (2 threads, robust): rtcIntersect1 " << m1
                  << " Mrays/s, rtcIntersect16 " << m16 << " Mrays/s.\n";
        }
    }
    std::ostringstream md;
    if (w != 1024 || h != 768)
        md << "Rendered at " << w << "×" << h << ", not the 1024×768 of the docs' tables.\n\n";
    md << "| scene | spp | precision | raycastd ms | rays (primary / shadow / reflected / "
          "refracted) | Mrays/s | POV-Ray ms | POV-Ray ÷ raycastd |\n"
       << "|---|---|---|---|---|---|---|---|\n";
    char buf[512];
    for (const Row& r : rows) {
        std::snprintf(buf, sizeof buf,
                      "| %s | %d | %s | %.0f | %llu / %llu / %llu / %llu | %.2f | ",
                      r.scene.c_str(), r.spp, r.precision.c_str(), r.ms,
                      static_cast<unsigned long long>(r.counts.primary),
                      static_cast<unsigned long long>(r.counts.shadow),
                      static_cast<unsigned long long>(r.counts.reflected),
                      static_cast<unsigned long long>(r.counts.refracted), r.mrays);
        md << buf;
        if (r.pov_ms > 0) {
            std::snprintf(buf, sizeof buf, "%.0f | %.2f× |\n", r.pov_ms, r.pov_ms / r.ms);
        } else {
            std::snprintf(buf, sizeof buf, "– | – |\n");
        }
        md << buf;
    }
    md << "\n" << extra.str();
    std::cout << md.str();
    if (!a.out.empty())
        std::ofstream(a.out) << md.str();
    return rows.empty() && a.write_pov.empty() ? 1 : 0;
}
