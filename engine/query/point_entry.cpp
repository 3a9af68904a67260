// QueryEngine's point-query entries (intersect.h): closest points through the point BVH (or the
// accelerator the scene has), each object's topology, and the trees built on first use.

#include <tbb/parallel_for.h>

#include "engine/accel/embree_accel.h"
#include "engine/accel/point_bvh.h"
#include "engine/accel/point_query.h"
#include "engine/accel/winding_bvh.h"
#include "engine/query/intersect.h"
#include "engine/query/parity_pieces.h"
#include "engine/query/per_object_once.h"

namespace raycastd::engine {

/// One lazily built WindingBvh per mesh object (never for spheres).
struct WindingTrees : PerObjectOnce<WindingBvh> {
    using PerObjectOnce::PerObjectOnce;
};

/// The scene's one PointBvh (slot 0), built on the first closest-point query.
struct PointTree : PerObjectOnce<PointBvh> {
    PointTree() : PerObjectOnce(1) {}
};

/// The scene's one ParityPieces (slot 0), built on the first query of the parity test.
struct ParitySlot : PerObjectOnce<ParityPieces> {
    ParitySlot() : PerObjectOnce(1) {}
};

std::size_t ParityPieces::memory_bytes() const {
    std::size_t n = first.capacity() * sizeof(std::uint32_t) +
                    object.capacity() * sizeof(std::uint32_t) +
                    ray_bounds.capacity() * sizeof(Bounds3) + grid.memory_bytes();
    for (const MeshComponents& c : of_object)
        n += sizeof(MeshComponents) + c.memory_bytes();
    return n;
}

namespace {

const PointBvh& point_bvh(PointTree& tree, const Scene& scene) {
    return tree.get(0, [&] { return std::make_unique<const PointBvh>(scene); });
}

}  // namespace

std::optional<PointHit> QueryEngine::closest_point(const Vec3d& p, double max_distance) const {
    if (accel_ && point_tree_)
        return point_bvh(*point_tree_, *scene_).closest_point(p, max_distance);
    if (accel_)
        return accel_->closest_point(p, max_distance);
    return linear_closest_point(*scene_, p, max_distance);
}

void QueryEngine::build_point_tree() const {
    if (accel_ && point_tree_)
        (void)point_bvh(*point_tree_, *scene_);
}

double QueryEngine::winding_number(std::uint32_t object, const Vec3d& p) const {
    const Object& o = scene_->objects[object];
    if (o.kind == ObjectKind::sphere)
        return 0.0;
    return winding_->get(object, [&] { return std::make_unique<const WindingBvh>(*o.mesh); })
        .winding_number(p);
}

const ParityPieces& QueryEngine::parity_pieces() const {
    return parity_->get(0, [&] {
        const Scene& s = *scene_;
        auto out = std::make_unique<ParityPieces>();
        out->of_object.resize(s.objects.size());
        // The meshes in parallel: each is one weld and one union-find pass (mesh/components.h).
        tbb::parallel_for(std::size_t(0), s.objects.size(), [&](std::size_t i) {
            if (s.objects[i].kind != ObjectKind::sphere && topology_[i].sign == SignMethod::parity)
                out->of_object[i] = find_components(*s.objects[i].mesh);
        });
        out->first.assign(s.objects.size(), 0);
        std::vector<Bounds3> boxes;
        for (std::uint32_t o = 0; o < s.objects.size(); ++o) {
            out->first[o] = static_cast<std::uint32_t>(boxes.size());
            for (const Bounds3& b : out->of_object[o].bounds) {
                out->object.push_back(o);
                boxes.push_back(b);
            }
        }
        out->grid = BoxGrid(boxes);
        out->ray_bounds = boxes;
        for (Bounds3& b : out->ray_bounds) {
            const double coords = max_component(max(abs(b.lo), abs(b.hi)));
            const double pad = max_component(b.diagonal()) * 0x1p-20 + coords * 0x1p-40;
            b.lo = b.lo - Vec3d{pad, pad, pad};
            b.hi = b.hi + Vec3d{pad, pad, pad};
        }
        return std::unique_ptr<const ParityPieces>(std::move(out));
    });
}

std::size_t QueryEngine::point_memory_bytes() const {
    return (winding_ ? winding_->memory_bytes() : 0) +
           (point_tree_ ? point_tree_->memory_bytes() : 0) +
           (parity_ ? parity_->memory_bytes() : 0);
}

void QueryEngine::prepare_points() {
    const Scene& s = *scene_;
    topology_.assign(s.objects.size(), MeshTopology{});
    tbb::parallel_for(std::size_t(0), s.objects.size(), [&](std::size_t i) {
        if (s.objects[i].kind != ObjectKind::sphere)
            topology_[i] = compute_topology(*s.objects[i].mesh);
    });
    winding_ = std::make_shared<WindingTrees>(s.objects.size());
    parity_ = std::make_shared<ParitySlot>();
    if (PointBvh::suits(s))
        point_tree_ = std::make_shared<PointTree>();
}

}  // namespace raycastd::engine
