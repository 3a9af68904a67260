#pragma once
// The topology of a triangle mesh, as `topology` in the scene response reports it (docs/api.md),
// and the sign method the point queries use for it.
//
// The mesh is welded first (weld.h), then counted two ways:
//   * the edge map (edge_map.h) over every triangle with three distinct corners: edges, boundary
//     and non-manifold edges, closedness, orientation, fans (non-manifold vertices), components;
//   * OpenMesh's half-edge structure (OpenMesh::TriConnectivity, add_face per triangle in file
//     order, after the edge map's orientation walk has turned flipped triangles round so that
//     a closed mesh with a flipped triangle is still one closed surface to it): the boundary
//     loops are its cycles of boundary half-edges. add_face refuses what a half-edge structure
//     cannot hold (a third face on an edge, a face at a vertex whose one-ring is already closed,
//     a face against a non-orientable walk); those are counted in refused_triangles, and the loops
//     are those of the triangles it accepted. OpenMesh's own messages about them (it prints to
//     std::cerr through omerr()) are switched off once for the process: the engine never prints.
//
// OpenMesh's add_face walks the one-ring of each of the face's vertices, so building costs
// Σ_v valence(v)² (measured: a fan of 100,000 triangles around one vertex, listed in random
// order, did not finish in two minutes). Past a budget of 32 per face (+4M; meshes of valence ~6
// cost about 18 per face), the half-edge structure is not built: `half_edge` is false, the
// boundary loops are then the connected boundaries of the edge map, and nothing is refused.
//
// Nor is it built for a *clean* mesh of more than 2¹⁸ faces (no non-manifold edge or vertex, no
// flipped face): add_face takes every face of such a mesh, and its boundary cycles are the edge
// map's own (count_boundary_loops; topology_test.cpp checks the two agree), while the structure
// for 1M triangles is ~55 MB of OpenMesh arrays and ~0.3 s of add_face: measured on 1M triangles
// (bench_points --registration-only, docs/loading.md), building it more than doubled the CPU time
// of a registration, against a budget of 30%. `half_edge` is false for those too.
//
// Euler characteristic χ = V − E + F over the welded vertices, the edges and the faces (for one
// closed orientable surface χ = 2 − 2g; for the Stanford bunny, genus 0 with 5 holes, 2 − 5 = −3).
//
// Cost: bench_points --registration-only times it against the rest of a registration
// (docs/loading.md).

#include <cstddef>
#include <cstdint>

#include "engine/geometry/mesh.h"

namespace raycastd::engine {

/// How the point queries decide inside/outside for a mesh (docs/api.md, `topology.sign`).
enum class SignMethod {
    parity,   ///< closed, consistently oriented, no zero-area triangle: exact crossing parity
    winding,  ///< anything else: the generalized winding number, inside where it is ≥ ½
};

/// "parity" or "winding".
const char* to_string(SignMethod s);

struct MeshTopology {
    std::size_t vertices = 0;   ///< distinct positions the triangles use (welded)
    std::size_t triangles = 0;  ///< as the mesh lists them, degenerate ones included
    bool closed = false;        ///< every edge has exactly two faces (and there is a face)
    std::size_t boundary_edges = 0;
    std::size_t boundary_loops = 0;  ///< cycles of boundary half-edges in OpenMesh's structure
    std::size_t non_manifold_edges = 0;
    std::size_t non_manifold_vertices = 0;
    std::size_t components = 0;
    std::int64_t euler_characteristic = 0;
    bool consistently_oriented = true;     ///< no edge is run the same way by two faces (or three)
    std::size_t degenerate_triangles = 0;  ///< zero area: (b−a)×(c−a) exactly zero
    std::size_t refused_triangles = 0;     ///< triangles OpenMesh's add_face refused
    /// OpenMesh's structure was built (false: over the valence budget, or a large clean mesh)
    bool half_edge = true;
    SignMethod sign = SignMethod::winding;
};

/// The topology of `mesh`. Never fails: non-manifold, non-orientable and degenerate input are
/// what it counts.
MeshTopology compute_topology(const TriangleMesh& mesh);

}  // namespace raycastd::engine
