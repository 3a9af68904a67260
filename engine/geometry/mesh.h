#pragma once
// TriangleMesh: indexed triangles in world space, in double precision (the truth the precise
// paths use; accelerators keep their own float copies).

#include <array>
#include <cstdint>
#include <vector>

#include "engine/geometry/triangle.h"
#include "engine/math/bounds.h"

namespace raycastd::engine {

struct TriangleMesh {
    std::vector<Vec3d> positions;
    std::vector<std::array<std::uint32_t, 3>> triangles;  ///< indices into positions
    /// Optional per-vertex shading normals (empty when the file has none; computed only on
    /// demand, by whoever needs them).
    std::vector<Vec3f> normals;
    /// Optional per-triangle material index into Scene::materials (empty: the object's).
    std::vector<std::uint32_t> triangle_material;
    /// Optional texture coordinates (u, v) of each triangle's three corners, in the order of
    /// its indices, in glTF's convention (engine/scene/texture.h); empty when the model has
    /// none. Per corner rather than per vertex because OBJ gives a vertex a different (u, v)
    /// on each side of a texture seam.
    std::vector<std::array<std::array<float, 2>, 3>> corner_uvs;

    std::size_t size() const { return triangles.size(); }
    Triangle triangle(std::size_t i) const {
        const auto& t = triangles[i];
        return {positions[t[0]], positions[t[1]], positions[t[2]]};
    }
    Bounds3 bounds() const {
        Bounds3 b;
        for (const auto& p : positions)
            b.extend(p);
        return b;
    }
};

}  // namespace raycastd::engine
