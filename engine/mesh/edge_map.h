#pragma once
// The edges of a welded triangle soup: which triangles share each edge and in which direction.
// Everything here counts every triangle with three distinct corners (a "face"); a triangle that
// repeats a corner is no face (it is one of MeshTopology's degenerate triangles).
//
// Built with a counting sort of the half-edges by their lower vertex (a CSR table, O(n)) and a
// sort of each vertex's few entries by the upper one, not a hash map of edges: two passes over
// contiguous arrays, measured at about a tenth of OpenMesh's add_face loop for the same mesh.

#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "engine/mesh/weld.h"

namespace raycastd::engine {

/// "No face" in EdgeMap::neighbour.
constexpr std::uint32_t kNoFace = 0xFFFFFFFFu;

struct EdgeMap {
    std::size_t faces = 0;               ///< triangles with three distinct corners
    std::size_t edges = 0;               ///< distinct undirected edges of the faces
    std::size_t boundary_edges = 0;      ///< edges of exactly one face
    std::size_t non_manifold_edges = 0;  ///< edges of three faces or more
    /// Edges of exactly two faces that both run the same way (one of the two is flipped).
    std::size_t same_direction_edges = 0;
    /// neighbour[3t + k]: the face across edge k of triangle t (corners k → k+1) when that edge
    /// has exactly two faces; kNoFace otherwise (boundary, non-manifold, or t is no face).
    std::vector<std::uint32_t> neighbour;
    /// same_direction[3t + k]: that neighbour runs the shared edge the same way as t.
    std::vector<std::uint8_t> same_direction;
    /// The boundary edges as (from, to) pairs, in the direction their face runs them.
    std::vector<std::pair<std::uint32_t, std::uint32_t>> boundary;
};

/// The edge map of the welded triangles.
EdgeMap build_edge_map(const WeldedTriangles& w);

/// Vertices whose faces do not form a single fan: grouped by the edges at the vertex that have
/// exactly two faces, they fall into more than one group (two cones meeting at their apex, a
/// vertex of a non-manifold edge). Vertices of no face are not counted.
std::size_t count_non_manifold_vertices(const WeldedTriangles& w, const EdgeMap& e);

/// Connected components: vertices joined by the triangles that use them (every triangle, faces or
/// not), counted over the vertices the triangles use.
std::size_t count_components(const WeldedTriangles& w);

/// The same components, as a label for each triangle: 0, 1, ... in order of each component's
/// first triangle; *count receives how many there are.
std::vector<std::uint32_t> label_components(const WeldedTriangles& w, std::uint32_t* count);

/// Connected boundaries: the boundary edges grouped by shared vertices. Equal to the number of
/// boundary loops except where two loops touch at a vertex (counted once here); for the meshes
/// whose half-edge structure is not built (topology.h).
std::size_t count_boundary_components(const WeldedTriangles& w, const EdgeMap& e);

/// Boundary loops of a mesh without non-manifold edges or vertices and without flipped faces:
/// each boundary vertex then has exactly one boundary edge leaving it (in its face's direction),
/// and the loops are the cycles of that map, as a half-edge structure's boundary half-edges
/// (OpenMesh's) form them, run the other way. nullopt when some vertex has two (the mesh is not
/// such a mesh after all).
std::optional<std::size_t> count_boundary_loops(const WeldedTriangles& w, const EdgeMap& e);

/// Σ over vertices of (faces at the vertex)²: what OpenMesh's add_face loop costs, up to a
/// constant (it walks a vertex's one-ring for each face added at it).
std::uint64_t valence_cost(const WeldedTriangles& w);

/// Per triangle, whether to reverse it so that it runs every shared edge against its neighbour:
/// a breadth-first walk over the manifold edges from the lowest triangle of each component,
/// which keeps that one as it is. A non-orientable part (a Möbius strip) keeps whatever the walk
/// reached first; triangles that are no face are never reversed.
std::vector<std::uint8_t> orientation_flips(const WeldedTriangles& w, const EdgeMap& e);

/// Whether triangle t of w has three distinct corners.
inline bool is_face(const std::array<std::uint32_t, 3>& t) {
    return t[0] != t[1] && t[1] != t[2] && t[0] != t[2];
}

}  // namespace raycastd::engine
