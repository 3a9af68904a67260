#pragma once
// Meshes for the topology and point-query tests: the cube with a face removed or a triangle
// flipped (the published models: engine/mesh/test_models.h).

#include <algorithm>
#include <array>
#include <map>
#include <utility>
#include <vector>

#include "engine/testing/scenes.h"

namespace raycastd::engine::testing {

/// The cube [lo, hi]³ (scenes.h's cube_object) without its z = hi face (triangles 2 and 3): one
/// square hole, 4 boundary edges.
inline Object open_cube_object(double lo, double hi) {
    Object o = cube_object(lo, hi);
    auto mesh = std::make_shared<TriangleMesh>(*o.mesh);
    mesh->triangles.erase(mesh->triangles.begin() + 2, mesh->triangles.begin() + 4);
    o.mesh = std::move(mesh);
    o.name = "open cube";
    return o;
}

/// The cube [lo, hi]³ with triangle `which` listed the other way round (facing inwards).
inline Object flipped_cube_object(double lo, double hi, std::size_t which = 0) {
    Object o = cube_object(lo, hi);
    auto mesh = std::make_shared<TriangleMesh>(*o.mesh);
    std::swap(mesh->triangles[which][1], mesh->triangles[which][2]);
    o.mesh = std::move(mesh);
    o.name = "flipped cube";
    return o;
}

/// The closed surface of a union of unit voxels (integer cells [x, x+1]×[y, y+1]×[z, z+1]): each
/// face between a filled and an empty cell as two triangles facing out, corners shared. Voxels
/// must meet face to face (no contact along an edge or a corner only), so that it is a manifold.
inline Object voxel_object(const std::vector<std::array<int, 3>>& cells) {
    std::map<std::array<int, 3>, std::uint32_t> ids;
    std::vector<Vec3d> p;
    auto id = [&](int x, int y, int z) {
        auto [it, inserted] =
            ids.emplace(std::array<int, 3>{x, y, z}, static_cast<std::uint32_t>(p.size()));
        if (inserted)
            p.push_back({double(x), double(y), double(z)});
        return it->second;
    };
    auto filled = [&](int x, int y, int z) {
        return std::find(cells.begin(), cells.end(), std::array<int, 3>{x, y, z}) != cells.end();
    };
    std::vector<std::array<std::uint32_t, 3>> t;
    for (const auto& c : cells) {
        for (int axis = 0; axis < 3; ++axis) {
            for (int side = 0; side < 2; ++side) {
                std::array<int, 3> n = c;
                n[axis] += side ? 1 : -1;
                if (filled(n[0], n[1], n[2]))
                    continue;
                // The face's corners, counter-clockwise seen from outside.
                const int u = (axis + 1) % 3, v = (axis + 2) % 3;
                std::array<int, 3> q[4];
                for (int k = 0; k < 4; ++k) {
                    q[k] = c;
                    q[k][axis] += side;
                }
                q[1][u] += 1;
                q[2][u] += 1;
                q[2][v] += 1;
                q[3][v] += 1;
                std::uint32_t i[4];
                for (int k = 0; k < 4; ++k)
                    i[k] = id(q[k][0], q[k][1], q[k][2]);
                if (side) {
                    t.push_back({i[0], i[1], i[2]});
                    t.push_back({i[0], i[2], i[3]});
                } else {
                    t.push_back({i[0], i[2], i[1]});
                    t.push_back({i[0], i[3], i[2]});
                }
            }
        }
    }
    return mesh_object("voxels", std::move(p), std::move(t));
}

/// An icosphere of balls_object: its centre, radius, and whether it faces inwards.
struct Ball {
    Vec3d centre;
    double radius = 1.0;
    bool inward = false;
};

/// Icospheres of `level` in one mesh object, one connected component each (the inward ones with
/// their triangles turned round): the parity test's pieces (engine/mesh/components.h).
inline Object balls_object(const std::vector<Ball>& balls, int level) {
    std::vector<Vec3d> p;
    std::vector<std::array<std::uint32_t, 3>> t;
    for (const Ball& b : balls) {
        const Object o = icosphere_object(level, b.centre, b.radius);
        const auto base = static_cast<std::uint32_t>(p.size());
        p.insert(p.end(), o.mesh->positions.begin(), o.mesh->positions.end());
        for (auto tri : o.mesh->triangles) {
            if (b.inward)
                std::swap(tri[1], tri[2]);
            t.push_back({tri[0] + base, tri[1] + base, tri[2] + base});
        }
    }
    return mesh_object("balls", std::move(p), std::move(t));
}

/// A scene of the given objects with the default material.
inline Scene scene_of(std::vector<Object> objects) {
    Scene s;
    s.materials.push_back(Material{});
    s.material_names.push_back("default");
    s.objects = std::move(objects);
    return s;
}

}  // namespace raycastd::engine::testing
