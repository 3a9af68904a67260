#include "engine/mesh/topology.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "engine/mesh/edge_map.h"
#include "engine/mesh/test_models.h"
#include "engine/testing/point_meshes.h"

namespace raycastd::engine {
namespace {

MeshTopology of(const Object& o) {
    return compute_topology(*o.mesh);
}

TEST(Topology, ClosedCube) {
    const MeshTopology t = of(testing::cube_object(0, 1));
    EXPECT_EQ(t.vertices, 8u);
    EXPECT_EQ(t.triangles, 12u);
    EXPECT_TRUE(t.closed);
    EXPECT_EQ(t.boundary_edges, 0u);
    EXPECT_EQ(t.boundary_loops, 0u);
    EXPECT_EQ(t.non_manifold_edges, 0u);
    EXPECT_EQ(t.non_manifold_vertices, 0u);
    EXPECT_EQ(t.components, 1u);
    EXPECT_EQ(t.euler_characteristic, 2);
    EXPECT_TRUE(t.consistently_oriented);
    EXPECT_EQ(t.degenerate_triangles, 0u);
    EXPECT_EQ(t.refused_triangles, 0u);
    EXPECT_TRUE(t.half_edge);
    EXPECT_EQ(t.sign, SignMethod::parity);
}

TEST(Topology, Icospheres) {
    for (int level = 0; level <= 4; ++level) {
        const MeshTopology t = of(testing::icosphere_object(level));
        EXPECT_EQ(t.triangles, 20u << (2 * level));
        EXPECT_EQ(t.vertices, 10u * (1u << (2 * level)) + 2u);
        EXPECT_TRUE(t.closed);
        EXPECT_EQ(t.euler_characteristic, 2);
        EXPECT_EQ(t.sign, SignMethod::parity);
    }
}

TEST(Topology, CubeWithAFaceRemovedHasOneHole) {
    const MeshTopology t = of(testing::open_cube_object(0, 1));
    EXPECT_EQ(t.triangles, 10u);
    EXPECT_FALSE(t.closed);
    EXPECT_EQ(t.boundary_edges, 4u);
    EXPECT_EQ(t.boundary_loops, 1u);
    EXPECT_EQ(t.euler_characteristic, 1);  // a disc
    EXPECT_TRUE(t.consistently_oriented);
    EXPECT_EQ(t.sign, SignMethod::winding);
}

TEST(Topology, AFlippedTriangleIsClosedButNotOriented) {
    const MeshTopology t = of(testing::flipped_cube_object(0, 1, 5));
    EXPECT_TRUE(t.closed);
    EXPECT_FALSE(t.consistently_oriented);
    // The orientation walk turns it round for OpenMesh: one closed surface, nothing refused.
    EXPECT_EQ(t.refused_triangles, 0u);
    EXPECT_EQ(t.boundary_loops, 0u);
    EXPECT_EQ(t.euler_characteristic, 2);
    EXPECT_EQ(t.sign, SignMethod::winding);
}

TEST(Topology, NonManifoldEdgesAndVerticesAreCountedNotFatal) {
    // Three triangles on the edge (0,1), and a fourth meeting the rest at vertex 0 only.
    TriangleMesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0},    {0, 1, 0},   {0, -1, 0},
                   {0, 0, 1}, {-1, -1, -1}, {-1, -2, -1}};
    m.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}, {0, 5, 6}};
    const MeshTopology t = compute_topology(m);
    EXPECT_EQ(t.non_manifold_edges, 1u);
    EXPECT_GE(t.non_manifold_vertices, 2u);  // 0 and 1 (the edge's ends; 0 is also a bow-tie)
    EXPECT_EQ(t.components, 1u);
    EXPECT_FALSE(t.closed);
    EXPECT_FALSE(t.consistently_oriented);
    EXPECT_GE(t.refused_triangles, 1u);  // OpenMesh takes two faces of an edge at most
    EXPECT_EQ(t.sign, SignMethod::winding);
}

TEST(Topology, BowTieVertex) {
    TriangleMesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 0, 0}, {-1, -1, 0}};
    m.triangles = {{0, 1, 2}, {0, 3, 4}};
    const MeshTopology t = compute_topology(m);
    EXPECT_EQ(t.non_manifold_vertices, 1u);
    EXPECT_EQ(t.non_manifold_edges, 0u);
    EXPECT_EQ(t.boundary_edges, 6u);
    EXPECT_EQ(t.components, 1u);
    EXPECT_EQ(t.euler_characteristic, 1);
}

TEST(Topology, DegenerateTrianglesAreCountedAndMakeItWinding) {
    Object o = testing::cube_object(0, 1);
    auto mesh = std::make_shared<TriangleMesh>(*o.mesh);
    mesh->triangles.push_back({0, 0, 1});    // a repeated corner
    mesh->positions.push_back({0.5, 0, 0});  // on the edge 0–1
    mesh->triangles.push_back({0, 1, 8});    // zero area, three distinct corners
    const MeshTopology t = compute_topology(*mesh);
    EXPECT_EQ(t.triangles, 14u);
    EXPECT_EQ(t.degenerate_triangles, 2u);
    EXPECT_EQ(t.sign, SignMethod::winding);
}

// A mesh of nothing but a triangle with three equal corners has no edges at all: the edge map's
// rows are all empty (fuzz_scene_doc found them offsetting a null pointer; UBSan catches it).
TEST(Topology, OnlyDegenerateTrianglesHaveNoEdges) {
    auto mesh = std::make_shared<TriangleMesh>();
    mesh->positions = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    mesh->triangles = {{0, 1, 2}};
    const MeshTopology t = compute_topology(*mesh);
    EXPECT_EQ(t.triangles, 1u);
    EXPECT_EQ(t.degenerate_triangles, 1u);
    EXPECT_EQ(t.boundary_edges, 0u);
    EXPECT_EQ(t.non_manifold_edges, 0u);
}

TEST(Topology, AHugeFanInRandomOrderDoesNotHang) {
    // 100,000 triangles around one vertex, listed in random order (OpenMesh's add_face walks a
    // vertex's one-ring; the edge map's per-vertex work is O(n log n)). Closed by a second fan,
    // so the surface is a double cone: closed, genus 0.
    const int n = 100000;
    TriangleMesh m;
    m.positions.push_back({0, 0, 1});
    m.positions.push_back({0, 0, -1});
    for (int i = 0; i < n; ++i) {
        const double a = 2 * M_PI * i / n;
        m.positions.push_back({std::cos(a), std::sin(a), 0});
    }
    for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(n); ++i) {
        const std::uint32_t a = 2 + i, b = 2 + (i + 1) % n;
        m.triangles.push_back({0, a, b});
        m.triangles.push_back({1, b, a});
    }
    std::shuffle(m.triangles.begin(), m.triangles.end(), std::mt19937(3));
    const MeshTopology t = compute_topology(m);
    EXPECT_TRUE(t.closed);
    EXPECT_EQ(t.euler_characteristic, 2);
    EXPECT_EQ(t.non_manifold_vertices, 0u);
    EXPECT_FALSE(t.half_edge);  // over add_face's valence budget: the edge map's counts only
    EXPECT_EQ(t.boundary_loops, 0u);
    EXPECT_EQ(t.refused_triangles, 0u);
}

TEST(Topology, LargeCleanMeshesCountTheirLoopsWithoutOpenMesh) {
    // 327,680 triangles (past 2¹⁸) with three holes far apart.
    Object o = testing::icosphere_object(7);
    auto mesh = std::make_shared<TriangleMesh>(*o.mesh);
    for (std::size_t t : {300000u, 150000u, 7u})
        mesh->triangles.erase(mesh->triangles.begin() + static_cast<std::ptrdiff_t>(t));
    const MeshTopology t = compute_topology(*mesh);
    EXPECT_FALSE(t.half_edge);
    EXPECT_EQ(t.boundary_edges, 9u);
    EXPECT_EQ(t.boundary_loops, 3u);
    EXPECT_EQ(t.euler_characteristic, -1);
    EXPECT_EQ(t.refused_triangles, 0u);
    EXPECT_TRUE(t.consistently_oriented);
    // The same count as OpenMesh's on a smaller cut of the same kind.
    Object small = testing::icosphere_object(4);
    auto cut = std::make_shared<TriangleMesh>(*small.mesh);
    for (std::size_t k : {4000u, 2000u, 7u})
        cut->triangles.erase(cut->triangles.begin() + static_cast<std::ptrdiff_t>(k));
    const MeshTopology s = compute_topology(*cut);
    EXPECT_TRUE(s.half_edge);
    EXPECT_EQ(s.boundary_loops, 3u);
}

TEST(Topology, WithoutTheHalfEdgeStructureBoundariesAreStillCounted) {
    // A disc fan of 100,000 triangles (open: one boundary loop), over the valence budget.
    const int n = 100000;
    TriangleMesh m;
    m.positions.push_back({0, 0, 0});
    for (int i = 0; i < n; ++i) {
        const double a = 2 * M_PI * i / n;
        m.positions.push_back({std::cos(a), std::sin(a), 0});
    }
    for (std::uint32_t i = 0; i < static_cast<std::uint32_t>(n); ++i)
        m.triangles.push_back({0, 1 + i, 1 + (i + 1) % n});
    const MeshTopology t = compute_topology(m);
    EXPECT_FALSE(t.half_edge);
    EXPECT_EQ(t.boundary_edges, static_cast<std::size_t>(n));
    EXPECT_EQ(t.boundary_loops, 1u);
    EXPECT_EQ(t.euler_characteristic, 1);
}

// --- An independent count: a std::map of edges, nothing shared with edge_map.cpp or OpenMesh ---

struct Reference {
    std::size_t vertices = 0, edges = 0, faces = 0, boundary = 0, non_manifold = 0;
    std::size_t same_direction = 0, components = 0;
    std::size_t non_manifold_vertices = 0;
};

Reference reference_counts(const TriangleMesh& m) {
    Reference r;
    std::map<std::array<double, 3>, std::size_t> ids;
    auto id = [&](std::uint32_t i) {
        const Vec3d& p = m.positions[i];
        return ids.emplace(std::array<double, 3>{p.x + 0.0, p.y + 0.0, p.z + 0.0}, ids.size())
            .first->second;
    };
    std::map<std::pair<std::size_t, std::size_t>, std::pair<int, int>> edges;  // up, down uses
    std::map<std::size_t, std::set<std::size_t>> adjacent;
    std::vector<std::array<std::size_t, 3>> faces;
    std::map<std::size_t, std::vector<std::size_t>> faces_at;
    for (const auto& t : m.triangles) {
        const std::size_t v[3] = {id(t[0]), id(t[1]), id(t[2])};
        for (int k = 0; k < 3; ++k) {
            adjacent[v[k]].insert(v[(k + 1) % 3]);
            adjacent[v[(k + 1) % 3]].insert(v[k]);
        }
        if (v[0] == v[1] || v[1] == v[2] || v[0] == v[2])
            continue;
        ++r.faces;
        for (std::size_t x : v)
            faces_at[x].push_back(faces.size());
        faces.push_back({v[0], v[1], v[2]});
        for (int k = 0; k < 3; ++k) {
            const std::size_t a = v[k], b = v[(k + 1) % 3];
            auto& e = edges[{std::min(a, b), std::max(a, b)}];
            (a < b ? e.first : e.second)++;
        }
    }
    r.vertices = ids.size();
    r.edges = edges.size();
    for (const auto& [key, uses] : edges) {
        const int n = uses.first + uses.second;
        r.boundary += n == 1;
        r.non_manifold += n > 2;
        r.same_direction += n == 2 && uses.first != 1;
    }
    // Fans by brute force: two faces at x are in one fan when they share an edge x–u of exactly
    // two faces; a vertex with more than one fan is non-manifold.
    auto shared_manifold_edge = [&](std::size_t x, const std::array<std::size_t, 3>& f,
                                    const std::array<std::size_t, 3>& g) {
        for (std::size_t u : f) {
            if (u == x || std::find(g.begin(), g.end(), u) == g.end())
                continue;
            const auto& e = edges.at({std::min(x, u), std::max(x, u)});
            if (e.first + e.second == 2)
                return true;
        }
        return false;
    };
    for (const auto& [x, at] : faces_at) {
        std::vector<int> fan(at.size(), -1);
        int fans = 0;
        for (std::size_t i = 0; i < at.size(); ++i) {
            if (fan[i] >= 0)
                continue;
            fan[i] = fans++;
            std::vector<std::size_t> stack = {i};
            while (!stack.empty()) {
                const std::size_t a = stack.back();
                stack.pop_back();
                for (std::size_t b = 0; b < at.size(); ++b) {
                    if (fan[b] < 0 && shared_manifold_edge(x, faces[at[a]], faces[at[b]])) {
                        fan[b] = fan[i];
                        stack.push_back(b);
                    }
                }
            }
        }
        r.non_manifold_vertices += fans > 1;
    }
    std::set<std::size_t> seen;
    for (const auto& [v, next] : adjacent) {
        if (!seen.insert(v).second)
            continue;
        ++r.components;
        std::vector<std::size_t> stack = {v};
        while (!stack.empty()) {
            const std::size_t x = stack.back();
            stack.pop_back();
            for (std::size_t y : adjacent[x]) {
                if (seen.insert(y).second)
                    stack.push_back(y);
            }
        }
    }
    return r;
}

void expect_matches_reference(const TriangleMesh& m, const MeshTopology& t) {
    const Reference r = reference_counts(m);
    EXPECT_EQ(t.vertices, r.vertices);
    EXPECT_EQ(t.boundary_edges, r.boundary);
    EXPECT_EQ(t.non_manifold_edges, r.non_manifold);
    EXPECT_EQ(t.non_manifold_vertices, r.non_manifold_vertices);
    EXPECT_EQ(t.components, r.components);
    EXPECT_EQ(t.euler_characteristic, static_cast<std::int64_t>(r.vertices) -
                                          static_cast<std::int64_t>(r.edges) +
                                          static_cast<std::int64_t>(r.faces));
    EXPECT_EQ(t.closed, r.faces > 0 && r.boundary == 0 && r.non_manifold == 0);
    EXPECT_EQ(t.consistently_oriented, r.same_direction == 0 && r.non_manifold == 0);
}

TEST(Topology, RandomSoupsMatchAnIndependentCount) {
    std::mt19937 rng(11);
    for (int trial = 0; trial < 50; ++trial) {
        TriangleMesh m;
        std::uniform_int_distribution<std::uint32_t> vid(0, 14);
        for (int i = 0; i < 15; ++i)
            m.positions.push_back(
                {static_cast<double>(i % 4), static_cast<double>(i / 4), i * 0.1});
        for (int i = 0; i < 40; ++i)
            m.triangles.push_back({vid(rng), vid(rng), vid(rng)});
        const MeshTopology t = compute_topology(m);
        expect_matches_reference(m, t);
        EXPECT_LE(t.refused_triangles, t.triangles);
    }
}

/// An icosphere of `level` with `removed` random faces taken out and `repeated` random faces
/// added again (every other one reversed): holes, and edges of three faces or more.
TriangleMesh with_faces_removed_and_repeated(int level, int removed, int repeated,
                                             std::mt19937& rng) {
    TriangleMesh m = *testing::icosphere_object(level).mesh;
    auto pick = [&] {
        return std::uniform_int_distribution<std::size_t>(0, m.triangles.size() - 1)(rng);
    };
    for (int k = 0; k < removed; ++k)
        m.triangles.erase(m.triangles.begin() + static_cast<std::ptrdiff_t>(pick()));
    for (int k = 0; k < repeated; ++k) {
        auto t = m.triangles[pick()];
        if (k % 2)
            std::swap(t[1], t[2]);
        m.triangles.push_back(t);
    }
    return m;
}

TEST(Topology, TwoSpheresTouchingAtAVertexPinchIt) {
    // Every edge has two faces, so each vertex's walk around its faces decides it; the one
    // shared vertex's walk comes back after the faces of one sphere only (two fans).
    Object a = testing::icosphere_object(2, {0, 0, 0}, 1.0);
    const Vec3d top = a.mesh->positions[0];
    Object b = testing::icosphere_object(2, top * 2.0, 1.0);  // its vertex −top lands on top
    TriangleMesh m = *a.mesh;
    for (const auto& t : b.mesh->triangles) {
        std::array<std::uint32_t, 3> u;
        for (int k = 0; k < 3; ++k) {
            const Vec3d& p = b.mesh->positions[t[k]];
            u[k] = static_cast<std::uint32_t>(m.positions.size());
            m.positions.push_back(length(p - top) < 1e-12 ? top : p);
        }
        m.triangles.push_back(u);
    }
    const MeshTopology t = compute_topology(m);
    EXPECT_EQ(t.non_manifold_vertices, 1u);
    EXPECT_EQ(t.non_manifold_edges, 0u);
    EXPECT_EQ(t.boundary_edges, 0u);
    EXPECT_EQ(t.components, 1u);
    expect_matches_reference(m, t);
}

TEST(Topology, SpheresWithFacesRemovedAndRepeatedMatchAnIndependentCount) {
    // Large meshes where most vertices are decided by the walk and the rest (at holes and at
    // the edges of a repeated face, which have three faces or more) by grouping their faces.
    std::mt19937 rng(18);
    for (int trial = 0; trial < 20; ++trial) {
        SCOPED_TRACE(trial);
        const TriangleMesh m = with_faces_removed_and_repeated(3, trial % 5, trial / 5, rng);
        expect_matches_reference(m, compute_topology(m));
    }
}

TEST(Topology, ALargeMeshWithHolesAndRepeatedFacesMatchesAnIndependentCount) {
    // 40,962 vertices and 81,920 triangles: more than one range of each parallel pass (the edge
    // map's rows, the vertices' walks), so their joins are in the count.
    std::mt19937 rng(19);
    const TriangleMesh m = with_faces_removed_and_repeated(6, 40, 12, rng);
    const MeshTopology t = compute_topology(m);
    EXPECT_GT(t.boundary_edges, 0u);
    EXPECT_GT(t.non_manifold_edges, 0u);
    expect_matches_reference(m, t);
}

TEST(Topology, TwoSidedTrianglesAreOneFanEachAndTwoAtASharedVertex) {
    // Two faces on the same three corners share both their edges at each corner: the walk
    // around a corner finds both edges leading back to the face it came from.
    TriangleMesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}};
    m.triangles = {{0, 1, 2}, {0, 2, 1}};
    MeshTopology t = compute_topology(m);
    EXPECT_EQ(t.non_manifold_vertices, 0u);
    EXPECT_TRUE(t.closed);
    expect_matches_reference(m, t);
    // A second such pair at corner 0: two fans there.
    m.triangles.push_back({0, 3, 4});
    m.triangles.push_back({0, 4, 3});
    t = compute_topology(m);
    EXPECT_EQ(t.non_manifold_vertices, 1u);
    expect_matches_reference(m, t);
}

TEST(Topology, PublishedModelsMatchAnIndependentCount) {
    if (!std::filesystem::exists(testing::models_dir()))
        GTEST_SKIP() << "models not found at " << testing::models_dir();
    const char* files[] = {"stanford-bunny/stanford-bunny.obj",
                           "bunny_ply/bunny.ply",
                           "spot/spot.obj",
                           "cow/cow.obj",
                           "fandisk/fandisk.obj",
                           "teapot_stl/teapot.stl",
                           "sphereWithHole/sphereWithHole.stl",
                           "ballA_off/ballA.off",
                           "suzanne/suzanne.obj",
                           "Duck/glTF-Binary/Duck.glb",
                           "spider/Spider_binary.stl",
                           "beetle/beetle.obj",
                           "cube_off/Cube.off",
                           "featuretype/featuretype.STL",
                           "Wuson/Wuson.stl"};
    int found = 0;
    for (const char* f : files) {
        auto o = testing::model_object(f);
        if (!o)
            continue;
        ++found;
        SCOPED_TRACE(f);
        const MeshTopology t = of(*o);
        std::printf(
            "%-36s V %6zu T %6zu closed %d bnd %4zu loops %3zu nme %3zu nmv %3zu comp %3zu "
            "chi %4lld oriented %d degen %3zu refused %3zu %s\n",
            f, t.vertices, t.triangles, t.closed, t.boundary_edges, t.boundary_loops,
            t.non_manifold_edges, t.non_manifold_vertices, t.components,
            static_cast<long long>(t.euler_characteristic), t.consistently_oriented,
            t.degenerate_triangles, t.refused_triangles, to_string(t.sign));
        expect_matches_reference(*o->mesh, t);
        // Where the mesh is clean, the edge map's own boundary cycles (what large clean meshes
        // report) are OpenMesh's.
        const WeldedTriangles w = weld(*o->mesh);
        const EdgeMap e = build_edge_map(w);
        if (e.non_manifold_edges == 0 && e.same_direction_edges == 0 &&
            t.non_manifold_vertices == 0) {
            EXPECT_TRUE(t.half_edge);
            EXPECT_EQ(count_boundary_loops(w, e), t.boundary_loops);
        }
    }
    if (found == 0)
        GTEST_SKIP() << "none of the models found at " << testing::models_dir();
}

TEST(Topology, StanfordBunnyAsTheApiDocumentsIt) {
    auto o = testing::model_object("stanford-bunny/stanford-bunny.obj");
    if (!o)
        GTEST_SKIP() << "models not found at " << testing::models_dir();
    const MeshTopology t = of(*o);
    EXPECT_EQ(t.vertices, 34834u);
    EXPECT_EQ(t.triangles, 69451u);
    EXPECT_FALSE(t.closed);
    EXPECT_EQ(t.boundary_edges, 223u);
    EXPECT_EQ(t.boundary_loops, 5u);
    EXPECT_EQ(t.non_manifold_edges, 0u);
    EXPECT_EQ(t.non_manifold_vertices, 0u);
    EXPECT_EQ(t.components, 1u);
    EXPECT_EQ(t.euler_characteristic, -3);
    EXPECT_TRUE(t.consistently_oriented);
    EXPECT_EQ(t.degenerate_triangles, 0u);
    EXPECT_EQ(t.sign, SignMethod::winding);
}

}  // namespace
}  // namespace raycastd::engine
