#pragma once
// The connected components of a mesh, each with its bounding box: what the crossing-parity test
// of engine/points/inside.cpp needs to cast a point's ray only as far as the components whose
// boxes hold the point, and to count only their crossings.
//
// Why that is enough, for a closed mesh (every edge of exactly two faces: MeshTopology::closed).
// The two faces of an edge share its corners, so they are in one component and every component
// is closed too: a 2-cycle mod 2, whose crossings along a path have a parity that depends only on
// the path's two ends (the mod-2 intersection number of a path with a closed surface; the
// Jordan–Brouwer separation theorem in its mod-2 form). A point outside the closed box of a
// component is outside it: a ray leaving the box away from it meets none of the component. So for
// any q outside the box of every component whose box holds p,
//   p inside the mesh  ⇔  Σ over those components C of (crossings of C on [p, q]) is odd,
// and the components whose boxes do not hold p count nothing. On the 1M-triangle scene of
// bench_points (200 icospheres in one mesh) a point's parity ray then crosses one sphere over
// the length of its box instead of every sphere to the scene's edge (docs/points.md).
//
// Components as MeshTopology counts them (edge_map.h count_components): triangles joined by
// shared welded corners (weld.h), so a format's repeated positions (STL) are one vertex.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "engine/geometry/mesh.h"
#include "engine/math/bounds.h"

namespace raycastd::engine {

struct MeshComponents {
    /// The component of each triangle, numbered 0, 1, ... in order of their first triangle;
    /// empty when the mesh is one component (or none).
    std::vector<std::uint32_t> of_triangle;
    /// The box of each component's corners (exact: the corners' own coordinates).
    std::vector<Bounds3> bounds;

    std::uint32_t component(std::uint32_t triangle) const {
        return of_triangle.empty() ? 0u : of_triangle[triangle];
    }
    std::size_t memory_bytes() const {
        return of_triangle.capacity() * sizeof(std::uint32_t) + bounds.capacity() * sizeof(Bounds3);
    }
};

/// The components of `mesh` and their boxes: one weld (a hash pass over the corners), one
/// union-find pass over the triangles, one pass for the boxes.
MeshComponents find_components(const TriangleMesh& mesh);

}  // namespace raycastd::engine
