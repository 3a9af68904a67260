#include "engine/mesh/topology.h"

#include <mutex>
#include <optional>
#include <vector>

#include <OpenMesh/Core/Mesh/TriConnectivity.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include "engine/mesh/edge_map.h"

namespace raycastd::engine {

namespace {

/// add_face's cost budget (topology.h): Σ valence² per face, plus a constant for small meshes.
constexpr std::uint64_t kValenceCostPerFace = 32;
constexpr std::uint64_t kValenceCostBase = 1u << 22;
/// Clean meshes (no non-manifold edge or vertex, no flipped face) of more faces than this are
/// counted without OpenMesh's structure (topology.h).
constexpr std::size_t kHalfEdgeMaxCleanFaces = 1u << 18;

/// OpenMesh reports each refused face on omerr() (std::cerr); the engine never prints, and the
/// count is in the result instead. Once for the process, before any mesh of ours is built.
void silence_openmesh() {
    static std::once_flag once;
    std::call_once(once, [] { omerr().disable(); });
}

struct HalfEdgeCounts {
    std::size_t boundary_loops = 0;
    std::size_t refused = 0;
};

/// OpenMesh's half-edge structure of the faces (reversed where `flip` says), and what it says.
/// `edges` is the edge map's count of distinct edges, which the structure never exceeds (add_face
/// refuses a face that would give an edge a third side): reserving 3 × faces, as for triangles
/// that share none, made its edge array a block twice the size it needed (7.9 MB for 82k faces),
/// and glibc, once such a block mapped on its own is freed, raises its mmap threshold to it and
/// keeps later blocks below it in the heap (docs/numerics.md, the memory of a scene).
HalfEdgeCounts half_edge_counts(const WeldedTriangles& w, const std::vector<std::uint8_t>& flip,
                                std::size_t faces, std::size_t edges) {
    HalfEdgeCounts out;
    OpenMesh::TriConnectivity m;
    m.reserve(w.vertices, edges, faces);
    for (std::uint32_t v = 0; v < w.vertices; ++v)
        m.new_vertex();
    OpenMesh::VertexHandle h[3];
    for (std::size_t t = 0; t < w.triangles.size(); ++t) {
        const auto& tri = w.triangles[t];
        if (!is_face(tri))
            continue;
        const bool reverse = !flip.empty() && flip[t];
        h[0] = OpenMesh::VertexHandle(static_cast<int>(tri[0]));
        h[1] = OpenMesh::VertexHandle(static_cast<int>(tri[reverse ? 2 : 1]));
        h[2] = OpenMesh::VertexHandle(static_cast<int>(tri[reverse ? 1 : 2]));
        if (!m.add_face(h, 3).is_valid())
            ++out.refused;
    }
    // Each cycle of boundary half-edges (next_halfedge_handle links a boundary to the next
    // boundary half-edge) is one loop; the walk is bounded by the number of half-edges, which a
    // valid structure never reaches.
    const std::size_t n = m.n_halfedges();
    std::vector<std::uint8_t> seen(n, 0);
    for (std::size_t i = 0; i < n; ++i) {
        const OpenMesh::HalfedgeHandle start(static_cast<int>(i));
        if (seen[i] || !m.is_boundary(start))
            continue;
        ++out.boundary_loops;
        OpenMesh::HalfedgeHandle he = start;
        for (std::size_t steps = 0; steps < n && !seen[static_cast<std::size_t>(he.idx())];
             ++steps) {
            seen[static_cast<std::size_t>(he.idx())] = 1;
            he = m.next_halfedge_handle(he);
        }
    }
    return out;
}

}  // namespace

const char* to_string(SignMethod s) {
    return s == SignMethod::parity ? "parity" : "winding";
}

MeshTopology compute_topology(const TriangleMesh& mesh) {
    silence_openmesh();
    MeshTopology out;
    out.triangles = mesh.size();
    out.degenerate_triangles = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, mesh.size(), 16384), std::size_t{0},
        [&](const tbb::blocked_range<std::size_t>& r, std::size_t n) {
            for (std::size_t t = r.begin(); t < r.end(); ++t)
                n += is_degenerate(mesh.triangle(t));
            return n;
        },
        [](std::size_t a, std::size_t b) { return a + b; });
    const WeldedTriangles w = weld(mesh);
    out.vertices = w.vertices;
    const EdgeMap e = build_edge_map(w);
    out.boundary_edges = e.boundary_edges;
    out.non_manifold_edges = e.non_manifold_edges;
    out.closed = e.faces > 0 && e.boundary_edges == 0 && e.non_manifold_edges == 0;
    out.consistently_oriented = e.same_direction_edges == 0 && e.non_manifold_edges == 0;
    out.euler_characteristic = static_cast<std::int64_t>(w.vertices) -
                               static_cast<std::int64_t>(e.edges) +
                               static_cast<std::int64_t>(e.faces);
    out.non_manifold_vertices = count_non_manifold_vertices(w, e);
    out.components = count_components(w);
    const bool clean =
        e.non_manifold_edges == 0 && e.same_direction_edges == 0 && out.non_manifold_vertices == 0;
    const std::optional<std::size_t> own_loops =
        clean && e.faces > kHalfEdgeMaxCleanFaces ? count_boundary_loops(w, e) : std::nullopt;
    if (own_loops) {
        // A large clean mesh: add_face would take every face, and its boundary cycles are the
        // edge map's; building the structure would only cost the registration (topology.h).
        out.half_edge = false;
        out.boundary_loops = *own_loops;
    } else if (valence_cost(w) <= kValenceCostPerFace * e.faces + kValenceCostBase) {
        // The orientation walk only where some edge says a triangle is flipped.
        const std::vector<std::uint8_t> flip =
            e.same_direction_edges > 0 ? orientation_flips(w, e) : std::vector<std::uint8_t>{};
        const HalfEdgeCounts he = half_edge_counts(w, flip, e.faces, e.edges);
        out.boundary_loops = he.boundary_loops;
        out.refused_triangles = he.refused;
    } else {
        out.half_edge = false;
        out.boundary_loops = count_boundary_components(w, e);
    }
    out.sign = out.closed && out.consistently_oriented && out.degenerate_triangles == 0
                   ? SignMethod::parity
                   : SignMethod::winding;
    return out;
}

}  // namespace raycastd::engine
