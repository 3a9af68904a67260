#pragma once
// Small scenes shared by the engine's tests.

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <string>
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

/// A sphere object.
inline Object sphere(std::string name, Vec3d c, double r, std::uint32_t material) {
    Object o;
    o.kind = ObjectKind::sphere;
    o.name = std::move(name);
    o.sphere = {c, r};
    o.material = material;
    return o;
}

/// A white point light of intensity 1 at p.
inline Light point_light(Vec3d p) {
    Light l;
    l.type = LightType::point;
    l.position = p;
    return l;
}

/// A white ambient light of intensity i.
inline Light ambient_light(double i) {
    Light l;
    l.type = LightType::ambient;
    l.intensity = {i, i, i};
    return l;
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

/// `m` as an STL stores it: three positions of its own for every triangle (welding joins them).
inline TriangleMesh triangle_soup(const TriangleMesh& m) {
    TriangleMesh soup;
    for (const auto& t : m.triangles) {
        const auto base = static_cast<std::uint32_t>(soup.positions.size());
        for (std::uint32_t k : t)
            soup.positions.push_back(m.positions[k]);
        soup.triangles.push_back({base, base + 1, base + 2});
    }
    return soup;
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

/// Random spheres (12), random triangles (20), and a closed icosphere of level 3 at (1, −1, 0.5)
/// of radius 2, all within ±6.5 of `offset` on each axis; the same scene for the same seed.
inline Scene random_scene(std::uint64_t seed, double offset = 0.0) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> pos(-5, 5), rad(0.05, 1.0);
    Scene s;
    s.materials.push_back(Material{});
    const Vec3d off{offset, offset, offset};
    for (int i = 0; i < 12; ++i) {
        Object o;
        o.kind = ObjectKind::sphere;
        o.name = "s" + std::to_string(i);
        o.sphere = {Vec3d{pos(rng), pos(rng), pos(rng)} + off, rad(rng)};
        s.objects.push_back(o);
    }
    for (int i = 0; i < 20; ++i) {
        const Vec3d a = Vec3d{pos(rng), pos(rng), pos(rng)} + off;
        const Vec3d b = a + Vec3d{pos(rng), pos(rng), pos(rng)} * 0.3;
        const Vec3d c = a + Vec3d{pos(rng), pos(rng), pos(rng)} * 0.3;
        s.objects.push_back(mesh_object("t" + std::to_string(i), {a, b, c}, {{0, 1, 2}}));
    }
    s.objects.push_back(icosphere_object(3, Vec3d{1, -1, 0.5} + off, 2.0));
    return s;
}

}  // namespace raycastd::engine::testing
