#include "engine/query/tracer.h"

#include "engine/accel/scene_scan.h"

namespace raycastd::engine {

Tracer::Tracer(const QueryEngine& engine, Precision precision, BuildHint hint)
    : engine_(engine),
      precision_(precision),
      scan_(hint == BuildHint::many_rays ? engine.scan_for_many_rays(precision) : nullptr),
      // The scan decides in double at every precision.
      frame_(scan_ ? FloatFrame{} : engine.float_frame(precision)) {}

Tracer::~Tracer() = default;

Precision Tracer::precision() const {
    if (scan_)
        return precision_ == Precision::fast ? Precision::fast : Precision::exact;
    return engine_.effective_precision(precision_);
}

std::optional<Hit> Tracer::closest(const Ray& ray, bool want_normal) const {
    // A far ray goes to QueryEngine's brute force, which moves it to the scene (scene_scan.h).
    if (scan_ && !scan_->far(ray))
        return scan_->closest(ray, want_normal);
    return engine_.closest(ray, precision_, want_normal);
}

void Tracer::closest_batch(const std::vector<Ray>& rays, std::vector<Hit>& out) const {
    out.resize(rays.size());
    closest_batch(rays.data(), rays.size(), out.data());
}

void Tracer::closest_batch(const Ray* rays, std::size_t n, Hit* out) const {
    if (scan_) {
        for (std::size_t i = 0; i < n; ++i) {
            out[i] = Hit{};
            if (!scan_->far(rays[i])) {
                scan_->closest(rays[i], /*want_normal=*/true, out[i]);
            } else if (const auto h = engine_.closest(rays[i], precision_, true)) {
                out[i] = *h;
            }
        }
        return;
    }
    QueryOptions q;
    q.precision = precision_;
    engine_.intersect_span(rays, n, q, out);  // intersect()'s answers (intersect.h)
}

void Tracer::occluded_batch(const std::vector<Ray>& rays,
                            std::vector<std::uint8_t>& blocked) const {
    blocked.resize(rays.size());
    occluded_batch(rays.data(), rays.size(), blocked.data());
}

void Tracer::occluded_batch(const Ray* rays, std::size_t n, std::uint8_t* blocked) const {
    if (scan_) {
        for (std::size_t i = 0; i < n; ++i) {
            blocked[i] =
                (scan_->far(rays[i]) ? engine_.occluded(rays[i], precision_) : scan_->any(rays[i]))
                    ? 1
                    : 0;
        }
        return;
    }
    engine_.occluded_batch(rays, n, precision_, blocked);
}

bool Tracer::occluded(const Ray& ray) const {
    if (scan_ && !scan_->far(ray))
        return scan_->any(ray);
    return engine_.occluded(ray, precision_);
}

}  // namespace raycastd::engine
