// QueryEngine's computed shading normals (intersect.h): built per mesh on first use, as the
// winding-number trees are (point_entry.cpp), so that a registration never pays for them.

#include "engine/query/intersect.h"
#include "engine/query/per_object_once.h"

namespace raycastd::engine {

/// One lazily computed CornerNormals per mesh object that has no normals of its own.
struct ComputedNormals : PerObjectOnce<CornerNormals> {
    using PerObjectOnce::PerObjectOnce;
};

void QueryEngine::prepare_normals() {
    normals_ = std::make_shared<ComputedNormals>(scene_->objects.size());
}

std::size_t QueryEngine::normals_memory_bytes() const {
    return normals_ ? normals_->memory_bytes() : 0;
}

const CornerNormals* QueryEngine::computed_normals(std::uint32_t object) const {
    const Object& o = scene_->objects[object];
    if (o.kind != ObjectKind::mesh || o.mesh->normals.size() == o.mesh->positions.size())
        return nullptr;
    return &normals_->get(object, [&] {
        return std::make_unique<const CornerNormals>(compute_corner_normals(*o.mesh));
    });
}

}  // namespace raycastd::engine
