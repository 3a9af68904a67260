// QueryEngine's point-query entries (intersect.h): closest points through the accelerator the
// scene has, each object's topology, and the winding-number trees built on first use.

#include <tbb/parallel_for.h>

#include "engine/accel/embree_accel.h"
#include "engine/accel/point_query.h"
#include "engine/accel/winding_bvh.h"
#include "engine/query/intersect.h"
#include "engine/query/per_object_once.h"

namespace raycastd::engine {

/// One lazily built WindingBvh per mesh object (never for spheres).
struct WindingTrees : PerObjectOnce<WindingBvh> {
    using PerObjectOnce::PerObjectOnce;
};

std::optional<PointHit> QueryEngine::closest_point(const Vec3d& p, double max_distance) const {
    if (accel_)
        return accel_->closest_point(p, max_distance);
    return linear_closest_point(*scene_, p, max_distance);
}

double QueryEngine::winding_number(std::uint32_t object, const Vec3d& p) const {
    const Object& o = scene_->objects[object];
    if (o.kind == ObjectKind::sphere)
        return 0.0;
    return winding_->get(object, [&] { return std::make_unique<const WindingBvh>(*o.mesh); })
        .winding_number(p);
}

std::size_t QueryEngine::point_memory_bytes() const {
    return winding_ ? winding_->memory_bytes() : 0;
}

void QueryEngine::prepare_points() {
    const Scene& s = *scene_;
    topology_.assign(s.objects.size(), MeshTopology{});
    tbb::parallel_for(std::size_t(0), s.objects.size(), [&](std::size_t i) {
        if (s.objects[i].kind != ObjectKind::sphere)
            topology_[i] = compute_topology(*s.objects[i].mesh);
    });
    winding_ = std::make_shared<WindingTrees>(s.objects.size());
}

}  // namespace raycastd::engine
