// QueryEngine's computed shading normals (intersect.h): built per mesh on first use, as the
// winding-number trees are (point_entry.cpp), so that a registration never pays for them.

#include <atomic>
#include <mutex>

#include "engine/query/intersect.h"

namespace raycastd::engine {

/// One lazily computed CornerNormals per object (null where none is needed, and until asked).
struct ComputedNormals {
    explicit ComputedNormals(std::size_t n) : once(n), normals(n) {}
    std::vector<std::once_flag> once;
    std::vector<std::unique_ptr<const CornerNormals>> normals;
    std::atomic<std::size_t> bytes{0};
};

void QueryEngine::prepare_normals() {
    normals_ = std::make_shared<ComputedNormals>(scene_->objects.size());
}

std::size_t QueryEngine::normals_memory_bytes() const {
    return normals_ ? normals_->bytes.load() : 0;
}

const CornerNormals* QueryEngine::computed_normals(std::uint32_t object) const {
    const Object& o = scene_->objects[object];
    if (o.kind != ObjectKind::mesh || o.mesh->normals.size() == o.mesh->positions.size())
        return nullptr;
    std::call_once(normals_->once[object], [&] {
        auto n = std::make_unique<const CornerNormals>(compute_corner_normals(*o.mesh));
        normals_->bytes += n->memory_bytes();
        normals_->normals[object] = std::move(n);
    });
    return normals_->normals[object].get();
}

}  // namespace raycastd::engine
