// bench_probe: one ray set of one workload through one precision, on one thread unless told
// otherwise, timed as the best and the median of N batches, with a checksum of the answers.
//
// bench_intersect measures every path against raw Embree on both cores of a shared host, where
// a run's figures move by ±20% from minute to minute (docs/benchmarks.md). A change to one path
// is better judged on that path alone, with two builds run alternately: the probe times one
// QueryEngine::intersect batch at a time, reusing its answer's buffers (no page faults in the
// timing), and prints the number of hits, the sum of their t and a hash of every answer, so
// that two builds that must answer alike can be seen to (docs/numerics.md reports its figures
// as "the single-threaded probe"). It uses bench_intersect's workloads, seeds and sizes
// (bench/workloads.h).
//
//   bench_probe [--workload A|B|C] [--rays camera|random] [--precision fast|refined|exact]
//               [--mode closest|any] [--repeats N] [--threads N] [--quick|--smoke] [--check]
//
//   --check    every ray is then asked again on its own, through QueryEngine::closest (or
//              ::occluded for --mode any), the single-ray entry points that trace no packet
//              and walk no group, and the probe exits 1 where any answer differs from the
//              batch's in t, object or primitive (or in blocked for any) at `exact`, where they
//              must agree bit for bit (EmbreeAccel.PacketsAgreeWithSingleRays). At `fast` and
//              `refined` a packet's float traversal may settle a graze differently, so the count
//              is printed and does not fail. CTest runs it on tiny sizes (bench_probe_smoke_*).

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <tbb/global_control.h>

#include "bench/timing.h"
#include "bench/workloads.h"
#include "engine/query/intersect.h"

namespace rb = raycastd::bench;
namespace re = raycastd::engine;

namespace {

struct Args {
    char workload = 'A';
    std::string rays = "random";
    re::Precision precision = re::Precision::exact;
    re::Mode mode = re::Mode::closest;
    int repeats = 5;
    int threads = 1;
    rb::WorkloadSizes sizes = rb::kFullSizes;
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

/// The value of `option`, a positive integer up to 10⁶, the whole argument (so "5x" and "0" are
/// refused).
int positive(const std::string& option, const char* s) {
    char* end = nullptr;
    const long v = std::strtol(s, &end, 10);
    if (end == s || *end != '\0' || v < 1 || v > 1000000)
        usage((option + " takes a whole number from 1 to 1000000").c_str());
    return static_cast<int>(v);
}

/// The value of `names` whose name is `s`; usage(why) where none is.
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
            const std::string w = value();
            if (w != "A" && w != "B" && w != "C")
                usage("--workload is A, B or C");
            a.workload = w[0];
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
            a.repeats = positive(arg, value());
        } else if (arg == "--threads") {
            a.threads = positive(arg, value());
        } else if (arg == "--quick") {
            a.sizes = rb::kQuickSizes;
        } else if (arg == "--smoke") {
            a.sizes = rb::kSmokeSizes;
        } else if (arg == "--check") {
            a.check = true;
        } else {
            usage(("unknown argument " + arg).c_str());
        }
    }
    return a;
}

/// What the probe prints of a batch's answers: the hits, the sum of their t (closest only), and
/// a hash of every answer's validity, object, primitive and t bits (FNV-1a), which tells two
/// builds' answers apart where the sums agree (two hits swapped, a primitive for its neighbour).
struct Checksum {
    std::size_t hits = 0;
    double t_sum = 0.0;
    std::uint64_t hash = 0xcbf29ce484222325u;

    void add(std::uint64_t v) {
        for (int byte = 0; byte < 8; ++byte) {
            hash ^= (v >> (8 * byte)) & 0xFFu;
            hash *= 0x100000001b3u;
        }
    }
};

Checksum checksum(const std::vector<re::Hit>& hits) {
    Checksum c;
    for (const re::Hit& h : hits) {
        c.add(h.valid() ? 1u : 0u);
        if (!h.valid())
            continue;
        ++c.hits;
        c.t_sum += h.t;
        std::uint64_t t_bits;
        std::memcpy(&t_bits, &h.t, sizeof t_bits);
        c.add(t_bits);
        c.add(std::uint64_t{h.object} << 32 | h.primitive);
    }
    return c;
}

}  // namespace

int main(int argc, char** argv) {
    const Args a = parse(argc, argv);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism,
                                static_cast<std::size_t>(a.threads));
    const rb::Workload w = rb::make_workload(a.workload, a.sizes);
    const std::vector<re::Ray> rays =
        rb::to_engine_rays(rb::ray_set(w, a.rays == "camera", a.sizes));
    if (rays.empty()) {
        std::fprintf(stderr, "bench_probe: the ray set is empty\n");
        return 1;
    }
    auto built = re::QueryEngine::build(std::make_shared<const re::Scene>(rb::to_engine_scene(w)));
    if (!built.ok()) {
        std::fprintf(stderr, "bench_probe: QueryEngine::build: %s\n",
                     built.status().message.c_str());
        return 1;
    }
    const re::QueryEngine& engine = **built;
    const re::QueryOptions opt{a.mode, a.precision, /*want_normal=*/true};
    // One batch untimed: the first query of a precision builds what it needs (exact's or fast's
    // BVH), and the answer's buffers reach their size, so that no timed batch pays their page
    // faults (72 MB of hits for 1M rays).
    re::QueryResult out;
    std::vector<double> times;
    for (int r = 0; r <= a.repeats; ++r) {
        re::Status s;
        const double t = rb::seconds([&] { s = engine.intersect(rays, opt, out); });
        if (!s.ok()) {
            std::fprintf(stderr, "bench_probe: intersect: %s\n", s.message.c_str());
            return 1;
        }
        if (r > 0)
            times.push_back(t);
    }
    std::sort(times.begin(), times.end());
    const double n = static_cast<double>(rays.size());
    const Checksum c = checksum(out.hits);
    std::printf(
        "%c %s rays (%zu), %s %s, %d thread%s: best %.3f Mrays/s, median %.3f of %d; "
        "%zu hits",
        a.workload, a.rays.c_str(), rays.size(), re::to_string(a.precision), re::to_string(a.mode),
        a.threads, a.threads == 1 ? "" : "s", n / times.front() / 1e6,
        n / times[times.size() / 2] / 1e6, a.repeats, c.hits);
    // An `any` answer says only whether the ray is blocked (its t is not a distance).
    if (a.mode == re::Mode::closest)
        std::printf(", sum of t %.17g", c.t_sum);
    std::printf(", answers' hash %016llx\n", static_cast<unsigned long long>(c.hash));
    if (!a.check)
        return 0;
    std::size_t differ = 0;
    for (std::size_t i = 0; i < rays.size(); ++i) {
        const re::Hit& b = out.hits[i];
        if (a.mode == re::Mode::any) {
            differ += b.valid() != engine.occluded(rays[i], a.precision) ? 1 : 0;
            continue;
        }
        const std::optional<re::Hit> h = engine.closest(rays[i], a.precision, opt.want_normal);
        if (b.valid() != h.has_value() ||
            (h && (b.t != h->t || b.object != h->object || b.primitive != h->primitive)))
            ++differ;
    }
    std::printf("each ray on its own: %zu of %zu answers differ from the batch's\n", differ,
                rays.size());
    return differ > 0 && a.precision == re::Precision::exact ? 1 : 0;
}
