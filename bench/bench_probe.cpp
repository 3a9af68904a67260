// bench_probe: one ray set of one workload through one precision, on one thread unless told
// otherwise, timed as the best and the median of N batches, with a checksum of the answers.
//
// bench_intersect measures every path against raw Embree on both cores of a shared host, where
// a run's figures move by ±20% from minute to minute (docs/benchmarks.md). A change to one path
// is better judged on that path alone, with two builds run alternately: the probe times one
// QueryEngine::intersect batch at a time, reusing its answer's buffers (no page faults in the
// timing), and prints the number of hits and the sum of their t, so that two builds that must
// answer alike can be seen to (docs/numerics.md reports its figures as "the single-threaded
// probe"). It uses bench_intersect's workloads, seeds and sizes.
//
//   bench_probe [--workload A|B|C] [--rays camera|random] [--precision fast|refined|exact]
//               [--mode closest|any] [--repeats N] [--threads N] [--quick|--smoke] [--check]
//
//   --check    the same rays are then asked one at a time (a batch of one each), and the probe
//              exits 1 where any answer differs from the batch's in t, object or primitive. At
//              `exact` they must agree bit for bit (a batch walks its rays in packets, a single
//              ray alone: EmbreeAccel.PacketsAgreeWithSingleRays); at `fast` and `refined` a
//              packet's float traversal may settle a graze differently, so the count is printed
//              and only `exact` fails on it. CTest runs it on tiny sizes (bench_probe_smoke_*).

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <tbb/global_control.h>

#include "bench/workloads.h"
#include "engine/query/intersect.h"

namespace rb = raycastd::bench;
namespace re = raycastd::engine;

namespace {

/// bench_intersect's sizes (its kFull, kQuick and kSmoke).
struct Sizes {
    int ico_level;
    int field_count, field_level;
    int spheres;
    int image;
    std::size_t random_rays;
};
constexpr Sizes kFull{6, 200, 4, 1000, 1024, std::size_t{1} << 20};
constexpr Sizes kQuick{4, 50, 3, 200, 256, std::size_t{1} << 16};
constexpr Sizes kSmoke{2, 8, 1, 20, 64, 4096};

struct Args {
    std::string workload = "A";
    std::string rays = "random";
    re::Precision precision = re::Precision::exact;
    re::Mode mode = re::Mode::closest;
    int repeats = 5;
    int threads = 1;
    Sizes sizes = kFull;
    bool check = false;
};

[[noreturn]] void usage(const char* why) {
    std::fprintf(stderr,
                 "bench_probe: %s\n"
                 "usage: bench_probe [--workload A|B|C] [--rays camera|random]\n"
                 "                   [--precision fast|refined|exact] [--mode closest|any]\n"
                 "                   [--repeats N] [--threads N] [--quick|--smoke] [--check]\n",
                 why);
    std::exit(2);
}

/// A positive integer, the whole argument (so "5x" and "0" are refused).
int positive(const char* s) {
    char* end = nullptr;
    const long v = std::strtol(s, &end, 10);
    if (end == s || *end != '\0' || v < 1 || v > 1000000)
        usage("expected a positive integer");
    return static_cast<int>(v);
}

/// The value of `names` whose name is `s`.
template <class T>
T named(const std::string& s, std::initializer_list<std::pair<const char*, T>> names,
        const char* why) {
    for (const auto& [name, v] : names) {
        if (s == name)
            return v;
    }
    usage(why);
}

Args parse(int argc, char** argv) {
    Args a;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        const auto value = [&]() -> const char* {
            if (i + 1 >= argc)
                usage(("missing value after " + arg).c_str());
            return argv[++i];
        };
        if (arg == "--workload") {
            a.workload = value();
            if (a.workload != "A" && a.workload != "B" && a.workload != "C")
                usage("--workload is A, B or C");
        } else if (arg == "--rays") {
            a.rays = value();
            if (a.rays != "camera" && a.rays != "random")
                usage("--rays is camera or random");
        } else if (arg == "--precision") {
            a.precision = named<re::Precision>(value(),
                                               {{"fast", re::Precision::fast},
                                                {"refined", re::Precision::refined},
                                                {"exact", re::Precision::exact}},
                                               "--precision is fast, refined or exact");
        } else if (arg == "--mode") {
            a.mode =
                named<re::Mode>(value(), {{"closest", re::Mode::closest}, {"any", re::Mode::any}},
                                "--mode is closest or any");
        } else if (arg == "--repeats") {
            a.repeats = positive(value());
        } else if (arg == "--threads") {
            a.threads = positive(value());
        } else if (arg == "--quick") {
            a.sizes = kQuick;
        } else if (arg == "--smoke") {
            a.sizes = kSmoke;
        } else if (arg == "--check") {
            a.check = true;
        } else {
            usage(("unknown argument " + arg).c_str());
        }
    }
    return a;
}

rb::Workload make_workload(const Args& a) {
    if (a.workload == "A")
        return rb::make_icosphere(a.sizes.ico_level);
    if (a.workload == "B")
        return rb::make_icosphere_field(a.sizes.field_count, a.sizes.field_level, rb::kFieldSeed);
    return rb::make_sphere_field(a.sizes.spheres, rb::kSphereSeed);
}

/// What the probe prints of a batch's answers: hits, and the sum of their t (closest only).
struct Checksum {
    std::size_t hits = 0;
    double t_sum = 0.0;
};

Checksum checksum(const std::vector<re::Hit>& hits) {
    Checksum c;
    for (const re::Hit& h : hits) {
        if (h.valid()) {
            ++c.hits;
            c.t_sum += h.t;
        }
    }
    return c;
}

}  // namespace

int main(int argc, char** argv) {
    const Args a = parse(argc, argv);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                static_cast<std::size_t>(a.threads));
    const rb::Workload w = make_workload(a);
    const std::vector<re::Ray> rays = rb::to_engine_rays(
        a.rays == "camera" ? rb::camera_rays(w, a.sizes.image, a.sizes.image)
                           : rb::random_rays(w, a.sizes.random_rays, rb::kRaySeed));
    auto built = re::QueryEngine::build(std::make_shared<const re::Scene>(rb::to_engine_scene(w)));
    if (!built.ok()) {
        std::fprintf(stderr, "bench_probe: QueryEngine::build: %s\n",
                     built.status().message.c_str());
        return 1;
    }
    const re::QueryEngine& engine = **built;
    const re::QueryOptions opt{a.mode, a.precision, /*want_normal=*/true};
    // The first query of a precision builds what it needs (exact's or fast's BVH): not timed.
    re::QueryResult out;
    if (!engine.intersect({rays.front()}, opt, out).ok())
        return 1;
    std::vector<double> seconds;
    for (int r = 0; r < a.repeats; ++r) {
        const auto start = std::chrono::steady_clock::now();
        const re::Status s = engine.intersect(rays, opt, out);
        seconds.push_back(
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        if (!s.ok()) {
            std::fprintf(stderr, "bench_probe: intersect: %s\n", s.message.c_str());
            return 1;
        }
    }
    std::sort(seconds.begin(), seconds.end());
    const double n = static_cast<double>(rays.size());
    const Checksum c = checksum(out.hits);
    std::printf(
        "%s %s rays (%zu), %s %s, %d thread%s: best %.3f Mrays/s, median %.3f of %d; "
        "%zu hits",
        a.workload.c_str(), a.rays.c_str(), rays.size(), re::to_string(a.precision),
        re::to_string(a.mode), a.threads, a.threads == 1 ? "" : "s", n / seconds.front() / 1e6,
        n / seconds[seconds.size() / 2] / 1e6, a.repeats, c.hits);
    // An `any` answer says only whether the ray is blocked (its t is not a distance).
    if (a.mode == re::Mode::closest)
        std::printf(", sum of t %.17g", c.t_sum);
    std::printf("\n");
    if (!a.check)
        return 0;
    std::size_t differ = 0;
    re::QueryResult one;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        if (!engine.intersect({rays[i]}, opt, one).ok())
            return 1;
        const re::Hit& b = out.hits[i];
        const re::Hit& s = one.hits.front();
        if (b.valid() != s.valid() ||
            (b.valid() && (b.t != s.t || b.object != s.object || b.primitive != s.primitive)))
            ++differ;
    }
    std::printf("one ray at a time: %zu of %zu answers differ from the batch's\n", differ,
                rays.size());
    return differ > 0 && a.precision == re::Precision::exact ? 1 : 0;
}
