#include "engine/query/intersect.h"

#include <tbb/parallel_for.h>

#include <cmath>

#include "engine/accel/linear_accel.h"

namespace raycastd::engine {

namespace {

/// Below this many rays a batch runs on the calling thread: spawning TBB tasks costs more
/// than tracing a few rays through a small scene.
constexpr std::size_t kSerialBatch = 64;

template <class F>
void for_each_ray(std::size_t n, F&& f) {
    if (n <= kSerialBatch) {
        for (std::size_t i = 0; i < n; ++i) f(i);
        return;
    }
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kSerialBatch),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t i = r.begin(); i != r.end(); ++i) f(i);
                      });
}

}  // namespace

const char* to_string(Mode m) {
    switch (m) {
        case Mode::closest: return "closest";
        case Mode::any: return "any";
        case Mode::all: return "all";
        case Mode::count: return "count";
    }
    return "closest";
}

const char* to_string(Precision p) {
    switch (p) {
        case Precision::fast: return "fast";
        case Precision::refined: return "refined";
        case Precision::exact: return "exact";
    }
    return "exact";
}

Status validate_ray(const Ray& ray, std::size_t index) {
    const std::string at = "/rays/" + std::to_string(index);
    const std::string which = "ray " + std::to_string(index) + ": ";
    if (!is_finite(ray.origin)) {
        return Status::error(Code::invalid_ray, which + "origin must be finite", at + "/origin");
    }
    if (!is_finite(ray.direction)) {
        return Status::error(Code::invalid_ray, which + "direction must be finite",
                             at + "/direction");
    }
    if (ray.direction == Vec3d{0.0, 0.0, 0.0}) {
        return Status::error(Code::invalid_ray, which + "direction must not be zero",
                             at + "/direction");
    }
    // |d|² must not overflow or underflow, or every quadratic and shear below breaks down.
    const double len2 = dot(ray.direction, ray.direction);
    if (!std::isfinite(len2) || len2 == 0.0) {
        return Status::error(Code::invalid_ray, which + "direction length out of range",
                             at + "/direction");
    }
    if (std::isnan(ray.tmin) || std::isnan(ray.tmax)) {
        return Status::error(Code::invalid_ray, which + "tmin and tmax must be numbers", at);
    }
    if (ray.tmin > ray.tmax) {
        return Status::error(Code::invalid_ray, which + "tmin > tmax", at + "/tmin");
    }
    return {};
}

Result<std::shared_ptr<const QueryEngine>> QueryEngine::build(std::shared_ptr<const Scene> scene) {
    if (!scene) return Status::error(Code::internal, "no scene");
    Status st = validate(*scene);
    if (!st.ok()) return st;
    return std::shared_ptr<const QueryEngine>(new QueryEngine(std::move(scene)));
}

Precision QueryEngine::effective_precision(Precision) const {
    // Every query is answered by the double-precision linear path for now, which is the exact
    // path; the Embree-backed fast and refined paths arrive with the accelerator.
    return Precision::exact;
}

QueryResult QueryEngine::intersect(const std::vector<Ray>& rays, const QueryOptions& opt) const {
    QueryResult out;
    out.precision = effective_precision(opt.precision);
    const std::size_t n = rays.size();
    const Scene& s = *scene_;
    switch (opt.mode) {
        case Mode::closest:
            out.hits.resize(n);
            for_each_ray(n, [&](std::size_t i) {
                if (auto h = linear_closest(s, rays[i], opt.want_normal)) out.hits[i] = *h;
            });
            break;
        case Mode::any:
            out.hits.resize(n);
            for_each_ray(n, [&](std::size_t i) {
                if (linear_any(s, rays[i])) out.hits[i].object = 0;
            });
            break;
        case Mode::all:
        case Mode::count: {
            std::vector<std::vector<Hit>> per_ray(n);
            for_each_ray(n, [&](std::size_t i) {
                linear_all(s, rays[i], opt.want_normal && opt.mode == Mode::all, per_ray[i]);
            });
            if (opt.mode == Mode::count) {
                out.counts.resize(n);
                for (std::size_t i = 0; i < n; ++i) {
                    out.counts[i] = static_cast<std::uint32_t>(per_ray[i].size());
                }
                break;
            }
            out.offsets.resize(n + 1, 0);
            for (std::size_t i = 0; i < n; ++i) {
                out.offsets[i + 1] = out.offsets[i] + static_cast<std::uint32_t>(per_ray[i].size());
            }
            out.hits.reserve(out.offsets[n]);
            for (auto& v : per_ray) out.hits.insert(out.hits.end(), v.begin(), v.end());
            break;
        }
    }
    return out;
}

}  // namespace raycastd::engine
