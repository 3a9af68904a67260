#pragma once
// Small scenes shared by the engine's tests.

#include <memory>

#include "engine/scene/scene.h"

namespace raycastd::engine::testing {

/// The tutorial's Question 1: spheres of radius 2 at (0,0,10), (0,3,8), (0,1,9).
inline Scene tutorial_spheres() {
    Scene s;
    s.materials.push_back(Material{});
    s.material_names.push_back("default");
    const Vec3d centers[3] = {{0, 0, 10}, {0, 3, 8}, {0, 1, 9}};
    for (int i = 0; i < 3; ++i) {
        Object o;
        o.kind = ObjectKind::sphere;
        o.name = "sphere " + std::to_string(i + 1);
        o.sphere = {centers[i], 2.0};
        s.objects.push_back(o);
    }
    return s;
}

/// A mesh object from positions and triangles.
inline Object mesh_object(std::string name, std::vector<Vec3d> positions,
                          std::vector<std::array<std::uint32_t, 3>> triangles) {
    auto mesh = std::make_shared<TriangleMesh>();
    mesh->positions = std::move(positions);
    mesh->triangles = std::move(triangles);
    Object o;
    o.kind = mesh->size() == 1 ? ObjectKind::triangle : ObjectKind::mesh;
    o.name = std::move(name);
    o.mesh = std::move(mesh);
    return o;
}

/// The closed axis-aligned cube [lo, hi]³ as 12 outward-facing triangles.
inline Object cube_object(double lo, double hi) {
    std::vector<Vec3d> p;
    for (int i = 0; i < 8; ++i) {
        p.push_back({(i & 1) ? hi : lo, (i & 2) ? hi : lo, (i & 4) ? hi : lo});
    }
    // Faces listed counter-clockwise seen from outside.
    std::vector<std::array<std::uint32_t, 3>> t = {
        {0, 2, 1}, {1, 2, 3},  // z = lo
        {4, 5, 6}, {5, 7, 6},  // z = hi
        {0, 1, 4}, {1, 5, 4},  // y = lo
        {2, 6, 3}, {3, 6, 7},  // y = hi
        {0, 4, 2}, {2, 4, 6},  // x = lo
        {1, 3, 5}, {3, 7, 5},  // x = hi
    };
    return mesh_object("cube", std::move(p), std::move(t));
}

}  // namespace raycastd::engine::testing
