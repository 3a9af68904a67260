#include "engine/mesh/components.h"

#include "engine/mesh/edge_map.h"
#include "engine/mesh/weld.h"

namespace raycastd::engine {

MeshComponents find_components(const TriangleMesh& mesh) {
    MeshComponents out;
    std::uint32_t count = 0;
    std::vector<std::uint32_t> labels = label_components(weld(mesh), &count);
    out.bounds.assign(count, Bounds3{});
    for (std::size_t t = 0; t < mesh.size(); ++t) {
        Bounds3& b = out.bounds[labels[t]];
        for (std::uint32_t v : mesh.triangles[t])
            b.extend(mesh.positions[v]);
    }
    if (count > 1)
        out.of_triangle = std::move(labels);
    return out;
}

}  // namespace raycastd::engine
