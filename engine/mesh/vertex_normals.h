#pragma once
// Shading normals for a mesh whose file has none (glTF without NORMAL, OBJ without vn, PLY
// without nx ny nz, STL, OFF): area-weighted vertex normals over the welded mesh, split at
// creases.
//
//   n(v, group) = normalize( Σ_{f ∋ v, f ∈ group} (b_f − a_f) × (c_f − a_f) )
//
// The cross product is twice the face's area times its unit normal, so the sum weights each
// face by its area (Max, "Weights for Computing Vertex Normals from Facet Normals", JGT 4(2),
// 1999, compares this with angle weighting; area weighting is what OpenMesh's and Blender's
// default smooth normals amount to on well-shaped meshes, and costs no trigonometry).
//
// Creases (smoothing groups): the faces around a welded vertex are clustered greedily in file
// order. A face joins the cluster whose first face (its seed) has the unit normal nearest its
// own, if the angle between them is at most kCreaseAngleDeg; otherwise it seeds a new cluster.
// Each cluster is one smoothing group with its own normal, so a cube keeps its edges sharp and
// a sphere's tessellation is smooth. Seeds are pairwise more than kCreaseAngleDeg apart, so a
// vertex has at most 12 clusters (unit vectors pairwise at least 60° apart number at most 12:
// the kissing number in three dimensions, Schütte & van der Waerden 1953), and the clustering
// costs O(valence) per vertex, not O(valence²): a fan of 100,000 triangles around one vertex is
// linear too (topology.h notes what quadratic costs there). The cost is memory traffic: about
// 0.4 µs per triangle (1.3M triangles in 0.5 s on the loaded 2-core machine), single-threaded.
//
// Welding (weld.h) joins positions that are exactly equal, so a file that repeats a vertex per
// face (STL) is smoothed across its faces; positions that are apart stay apart.
//
// Memory: one index per corner (12 B per triangle) and one float normal per (vertex, group)
// (12 B each; about half a vertex per triangle on a closed mesh, more at creases): ~18-24 B per
// triangle, built only for a mesh that is rendered (QueryEngine::shading_normals).

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "engine/geometry/mesh.h"

namespace raycastd::engine {

/// The largest angle between two faces' normals that is still smoothed across (degrees).
constexpr double kCreaseAngleDeg = 60.0;

/// A normal per corner of each triangle, by index into `normals`.
struct CornerNormals {
    std::vector<Vec3f> normals;                         ///< unit normals
    std::vector<std::array<std::uint32_t, 3>> corners;  ///< per triangle, one index per corner

    std::size_t memory_bytes() const {
        return normals.capacity() * sizeof(Vec3f) + corners.capacity() * sizeof(corners[0]);
    }
};

/// Area-weighted vertex normals of `mesh`, split where faces meet at more than kCreaseAngleDeg.
/// normals[0] is (0, 0, 0): the corners of a degenerate (zero-area, never hit) triangle point at
/// it, and it joins no group. Never fails.
CornerNormals compute_corner_normals(const TriangleMesh& mesh);

}  // namespace raycastd::engine
