#pragma once
// Small scenes shared by the engine's tests.

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <utility>

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

/// A closed icosphere: the icosahedron subdivided `level` times (20·4^level triangles), shared
/// vertices projected onto the sphere, faces counter-clockwise seen from outside.
inline Object icosphere_object(int level, Vec3d center = {0, 0, 0}, double radius = 1.0) {
    const double g = (1.0 + std::sqrt(5.0)) / 2.0;
    std::vector<Vec3d> p = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0},
                            {0, -1, g}, {0, 1, g}, {0, -1, -g}, {0, 1, -g},
                            {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
    for (auto& v : p)
        v = normalize(v);
    std::vector<std::array<std::uint32_t, 3>> t = {
        {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
        {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
        {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    for (int l = 0; l < level; ++l) {
        std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
        auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
            auto key = std::minmax(a, b);
            auto it = mid.find(key);
            if (it != mid.end())
                return it->second;
            p.push_back(normalize((p[a] + p[b]) * 0.5));
            const auto id = static_cast<std::uint32_t>(p.size() - 1);
            mid.emplace(key, id);
            return id;
        };
        std::vector<std::array<std::uint32_t, 3>> next;
        for (const auto& f : t) {
            const auto a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
            next.push_back({f[0], a, c});
            next.push_back({f[1], b, a});
            next.push_back({f[2], c, b});
            next.push_back({a, b, c});
        }
        t.swap(next);
    }
    for (auto& v : p)
        v = center + v * radius;
    return mesh_object("icosphere", std::move(p), std::move(t));
}

}  // namespace raycastd::engine::testing
