#include "engine/query/tracer.h"

#include "engine/accel/embree_accel.h"

namespace raycastd::engine {

Tracer::Tracer(const QueryEngine& engine, Precision precision, BuildHint hint)
    : engine_(engine),
      precision_(precision),
      own_bvh_(hint == BuildHint::many_rays ? engine.bvh_for_many_rays(precision) : nullptr),
      frame_(own_bvh_ ? own_bvh_->float_frame() : engine.float_frame(precision)) {}

Tracer::~Tracer() = default;

Precision Tracer::precision() const {
    return own_bvh_ ? precision_ : engine_.effective_precision(precision_);
}

std::optional<Hit> Tracer::closest(const Ray& ray, bool want_normal) const {
    if (own_bvh_)
        return own_bvh_->closest(ray, precision_, want_normal);
    return engine_.closest(ray, precision_, want_normal);
}

void Tracer::closest_batch(const std::vector<Ray>& rays, std::vector<Hit>& out) const {
    if (own_bvh_) {
        out.assign(rays.size(), Hit{});
        own_bvh_->closest_range(rays.data(), rays.size(), precision_, /*want_normal=*/true,
                                out.data());
        return;
    }
    QueryOptions q;
    q.precision = precision_;
    QueryResult result;
    engine_.intersect(rays, q, result);
    out.swap(result.hits);
}

void Tracer::occluded_batch(const std::vector<Ray>& rays, std::vector<Hit>& out) const {
    if (own_bvh_) {
        out.assign(rays.size(), Hit{});
        own_bvh_->any_range(rays.data(), rays.size(), precision_, out.data());
        return;
    }
    QueryOptions q;
    q.precision = precision_;
    q.mode = Mode::any;
    QueryResult result;
    engine_.intersect(rays, q, result);
    out.swap(result.hits);
}

bool Tracer::occluded(const Ray& ray) const {
    if (own_bvh_)
        return own_bvh_->any(ray, precision_);
    return engine_.occluded(ray, precision_);
}

}  // namespace raycastd::engine
