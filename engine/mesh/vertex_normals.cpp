#include "engine/mesh/vertex_normals.h"

#include <cmath>

#include "engine/math/float_bounds.h"
#include "engine/mesh/weld.h"

namespace raycastd::engine {

namespace {

/// One smoothing group at a vertex: the unit normal of its seed face and the area-weighted sum.
struct Group {
    Vec3d seed;
    Vec3d sum;
};

}  // namespace

CornerNormals compute_corner_normals(const TriangleMesh& mesh) {
    const WeldedTriangles w = weld(mesh);
    const std::size_t nt = mesh.triangles.size();
    CornerNormals out;
    out.normals.push_back(Vec3f{0.0f, 0.0f, 0.0f});
    out.corners.assign(nt, {0u, 0u, 0u});

    // Per face, the unit normal and twice the area (|(b − a) × (c − a)|), once; the area is
    // zero for a degenerate face (two welded corners alike make b − a or c − a exactly zero).
    std::vector<Vec3d> unit(nt);
    std::vector<double> area(nt);
    // A mesh beyond 2^±250 across has its edges brought to unit size by a power of two first
    // (the areas keep their ratios): a cross product of edges 1e300 long overflows, one of edges
    // 1e-300 long underflows, and every face of such a mesh had counted as degenerate (flat
    // shading). Ordinary meshes are computed as before, bit for bit.
    const Bounds3 b = mesh.bounds();
    const double edge_scale = unit_scale(b.empty() ? 0.0 : max_abs(b.diagonal()));
    for (std::size_t t = 0; t < nt; ++t) {
        const Triangle tri = mesh.triangle(t);
        const Vec3d n = cross((tri.b - tri.a) * edge_scale, (tri.c - tri.a) * edge_scale);
        const double len = length(n);
        const bool ok = len > 0.0 && std::isfinite(len);
        area[t] = ok ? len : 0.0;
        unit[t] = ok ? n / len : Vec3d{};
    }
    const auto usable = [&](std::size_t t) { return area[t] > 0.0; };

    // The faces around each welded vertex (compressed rows: faces[start[v] .. start[v + 1])).
    std::vector<std::uint32_t> start(static_cast<std::size_t>(w.vertices) + 1, 0);
    for (std::size_t t = 0; t < nt; ++t) {
        if (usable(t)) {
            for (std::uint32_t v : w.triangles[t])
                ++start[v + 1];
        }
    }
    for (std::size_t v = 0; v < w.vertices; ++v)
        start[v + 1] += start[v];
    std::vector<std::uint32_t> faces(start.back());
    {
        std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
        for (std::size_t t = 0; t < nt; ++t) {
            if (usable(t)) {
                for (std::uint32_t v : w.triangles[t])
                    faces[fill[v]++] = static_cast<std::uint32_t>(t);
            }
        }
    }

    const double cos_crease = std::cos(kCreaseAngleDeg * M_PI / 180.0);
    std::vector<Group> groups;
    std::vector<std::uint32_t> group_of;
    out.normals.reserve(w.vertices + 1);
    for (std::uint32_t v = 0; v < w.vertices; ++v) {
        groups.clear();
        group_of.clear();
        for (std::uint32_t i = start[v]; i < start[v + 1]; ++i) {
            const Vec3d& n = unit[faces[i]];
            // The nearest seed within the crease angle; seeds are pairwise further apart than
            // that, so there are few of them (vertex_normals.h).
            std::uint32_t best = static_cast<std::uint32_t>(groups.size());
            double best_dot = cos_crease;
            for (std::uint32_t g = 0; g < groups.size(); ++g) {
                const double d = dot(n, groups[g].seed);
                if (d >= best_dot) {
                    best_dot = d;
                    best = g;
                }
            }
            if (best == groups.size())
                groups.push_back({n, Vec3d{}});
            groups[best].sum += n * area[faces[i]];
            group_of.push_back(best);
        }
        const auto base = static_cast<std::uint32_t>(out.normals.size());
        for (const Group& g : groups)
            out.normals.push_back(Vec3f(normalize(g.sum)));
        for (std::uint32_t i = start[v]; i < start[v + 1]; ++i) {
            const std::uint32_t t = faces[i];
            for (int k = 0; k < 3; ++k) {
                if (w.triangles[t][k] == v)
                    out.corners[t][k] = base + group_of[i - start[v]];
            }
        }
    }
    return out;
}

}  // namespace raycastd::engine
