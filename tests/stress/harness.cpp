#include "tests/stress/harness.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace raycastd::stress {

using engine::Hit;
using engine::Precision;
using engine::QueryEngine;
using engine::QueryOptions;
using engine::Ray;
using engine::Scene;

namespace {

double max_of(const std::vector<double>& v) {
    return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
}
double median_of(std::vector<double> v) {
    if (v.empty())
        return 0.0;
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return *mid;
}
Quad qabs(Quad v) {
    return v < 0 ? -v : v;
}

/// The reference crossing the engine's hit corresponds to: same object and primitive, the
/// nearest in t (a sphere has two).
const RefCrossing* match(const RefAnswer& ref, const Hit& h) {
    const RefCrossing* best = nullptr;
    for (const RefCrossing& c : ref.crossings) {
        if (c.parallel || c.object != h.object || c.primitive != h.primitive)
            continue;
        if (!best || qabs(c.t - Quad(h.t)) < qabs(best->t - Quad(h.t)))
            best = &c;
    }
    return best;
}

double tie_band(const Bands& b, Quad t, double t_scale) {
    return std::max(b.tie_ulps * ulp(to_double(t)), b.tie_rel * t_scale);
}

}  // namespace

double ModeStats::max_rel() const {
    return max_of(rel_err);
}
double ModeStats::median_rel() const {
    return median_of(rel_err);
}
double ModeStats::max_ulps() const {
    return max_of(ulp_err);
}
double ModeStats::median_ulps() const {
    return median_of(ulp_err);
}

std::string ModeStats::summary() const {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "%-8s %-12s rays %6zu judged %6zu near-ties %5zu (differ %4zu) | t rel max "
                  "%.3g med %.3g | ulps max %.3g med %.3g | wrong hit/miss %zu object %zu "
                  "leaks %zu t_err-violations %zu | %.1f ns/ray",
                  mode.c_str(), path.c_str(), rays, judged, near_ties, near_tie_disagree, max_rel(),
                  median_rel(), max_ulps(), median_ulps(), wrong_hit, wrong_object, leaks,
                  t_err_violations, rays ? seconds * 1e9 / double(rays) : 0.0);
    return buf;
}

std::size_t primitive_count(const Scene& scene) {
    return scene.triangle_count() + scene.sphere_count();
}

void pad_for_embree(Scene& scene, std::vector<bool>& closed) {
    const engine::Bounds3 b = scene.bounds();
    const engine::Vec3d c = b.empty() ? engine::Vec3d{} : b.center();
    const double size = b.empty() ? 1.0 : std::max(engine::length(b.diagonal()), 1e-300);
    closed.resize(scene.objects.size(), false);
    // Tiny spheres on a ring just outside the bounds: they widen Embree's frame by about a
    // quarter, and a ray that meets one anyway is judged like any other.
    for (int k = 0; primitive_count(scene) <= 16; ++k) {
        const double phi = 2.399963229728653 * k;  // golden angle: spread, deterministic
        engine::Object o;
        o.kind = engine::ObjectKind::sphere;
        o.name = "pad " + std::to_string(k);
        o.sphere.center =
            c + engine::Vec3d{std::cos(phi), std::sin(phi), 0.3 * std::cos(3 * phi)} * (0.6 * size);
        o.sphere.radius = 1e-3 * size;
        scene.objects.push_back(o);
        closed.push_back(false);
    }
}

ReferenceAnswers reference_answers(const StressCase& c) {
    ReferenceAnswers out;
    const Bands wide = float_bands(), tight = exact_bands();
    out.exact.reserve(c.rays.size());
    out.coarse.reserve(c.rays.size());
    for (const Ray& r : c.rays) {
        const std::vector<RefCrossing> xs = reference_crossings(*c.scene, r, wide);
        out.exact.push_back(classify(xs, r, tight, c.closed));
        out.coarse.push_back(classify(xs, r, wide, c.closed));
    }
    return out;
}

ModeStats judge(const StressCase& c, const std::vector<RefAnswer>& refs,
                const std::vector<Hit>& hits, const std::string& mode, const std::string& path) {
    ModeStats s;
    s.mode = mode;
    s.path = path;
    s.rays = hits.size();
    const Bands bands = mode == "exact" ? exact_bands() : float_bands();
    for (std::size_t i = 0; i < hits.size(); ++i) {
        const RefAnswer& ref = refs[i];
        const Hit& h = hits[i];
        if (!ref.hit_robust) {
            ++s.near_ties;
            if (h.valid() != ref.hit || (h.valid() && h.object != ref.object)) {
                ++s.near_tie_disagree;
            }
            continue;
        }
        ++s.judged;
        if (!ref.hit) {
            if (h.valid())
                ++s.wrong_hit;
            continue;
        }
        if (!h.valid()) {
            ++s.wrong_hit;
            if (ref.first_on_closed)
                ++s.leaks;
            continue;
        }
        const RefCrossing* x = match(ref, h);
        if (!x) {  // a primitive the reference says is missed by more than the band
            ++s.wrong_object;
            continue;
        }
        const RefCrossing* first = nullptr;
        for (const RefCrossing& y : ref.crossings) {
            if (!y.parallel && y.t == ref.t_first_robust)
                first = &y;
        }
        const double tb = first ? tie_band(bands, first->t, first->t_scale) : 0.0;
        if (x->t > ref.t_first_robust + tb) {
            // The engine's hit is real but not the first: it skipped a robust closer one.
            if (first && first->object == h.object && ref.first_on_closed) {
                ++s.leaks;
            } else {
                ++s.wrong_object;
            }
            continue;
        }
        if (ref.object_robust && h.object != ref.object) {
            ++s.wrong_object;
            continue;
        }
        // A sphere candidate inside the band has no real root in quad: t is not comparable.
        const bool sphere = c.scene->objects[h.object].kind == engine::ObjectKind::sphere;
        if (sphere && std::abs(x->margin) <= bands.decision)
            continue;
        const Quad diff = qabs(Quad(h.t) - x->t);
        const double tr = to_double(x->t);
        s.rel_err.push_back(tr != 0.0 ? to_double(diff / qabs(x->t)) : to_double(diff));
        s.ulp_err.push_back(to_double(diff) / ulp(tr));
        if (std::getenv("STRESS_DEBUG") && s.ulp_err.back() > 4 && mode == "exact") {
            const Ray& r = c.rays[i];
            std::fprintf(stderr,
                         "DEBUG %s ray %zu o=(%a %a %a) d=(%a %a %a) tmin=%g t=%a tref=%a obj=%u "
                         "refobj=%u margin=%g\n",
                         c.suite.c_str(), i, r.origin.x, r.origin.y, r.origin.z, r.direction.x,
                         r.direction.y, r.direction.z, r.tmin, h.t, tr, h.object, ref.object,
                         x->margin);
        }
        if (diff > Quad(h.t_err))
            ++s.t_err_violations;
    }
    return s;
}

std::vector<ModeStats> evaluate(const StressCase& c, int repeats) {
    auto built = QueryEngine::build(c.scene);
    std::vector<ModeStats> out;
    if (!built.ok()) {
        std::fprintf(stderr, "evaluate(%s): %s\n", c.suite.c_str(), built.status().message.c_str());
        return out;
    }
    const std::shared_ptr<const QueryEngine> engine = *built;
    const ReferenceAnswers refs = reference_answers(c);
    const bool brute = engine->brute_force();
    const std::vector<Precision> modes =
        brute ? std::vector<Precision>{Precision::exact}
              : std::vector<Precision>{Precision::fast, Precision::refined, Precision::exact};
    for (Precision p : modes) {
        QueryOptions opt;
        opt.precision = p;
        opt.want_normal = false;
        engine::QueryResult res;
        engine->intersect(c.rays, opt, res);  // warm-up (the exact BVH is built lazily)
        double best = 1e300;
        for (int k = 0; k < std::max(1, repeats); ++k) {
            const auto t0 = std::chrono::steady_clock::now();
            engine->intersect(c.rays, opt, res);
            const auto t1 = std::chrono::steady_clock::now();
            best = std::min(best, std::chrono::duration<double>(t1 - t0).count());
        }
        const bool exact = p == Precision::exact;
        ModeStats s = judge(c, exact ? refs.exact : refs.coarse, res.hits, engine::to_string(p),
                            brute ? "brute force" : "embree");
        s.seconds = best;
        out.push_back(std::move(s));
    }
    return out;
}

void merge(ModeStats& into, const ModeStats& from) {
    into.rays += from.rays;
    into.near_ties += from.near_ties;
    into.near_tie_disagree += from.near_tie_disagree;
    into.judged += from.judged;
    into.wrong_hit += from.wrong_hit;
    into.wrong_object += from.wrong_object;
    into.leaks += from.leaks;
    into.t_err_violations += from.t_err_violations;
    into.rel_err.insert(into.rel_err.end(), from.rel_err.begin(), from.rel_err.end());
    into.ulp_err.insert(into.ulp_err.end(), from.ulp_err.begin(), from.ulp_err.end());
    into.seconds += from.seconds;
}

std::vector<SuiteStats> evaluate_suites(const std::vector<StressCase>& cases, int repeats) {
    std::vector<SuiteStats> out;
    for (const StressCase& c : cases) {
        for (const ModeStats& m : evaluate(c, repeats)) {
            auto it = std::find_if(out.begin(), out.end(), [&](const SuiteStats& s) {
                return s.suite == c.suite && s.stats.mode == m.mode && s.stats.path == m.path;
            });
            if (it == out.end()) {
                out.push_back({c.suite, m});
            } else {
                merge(it->stats, m);
            }
        }
    }
    return out;
}

}  // namespace raycastd::stress
