#pragma once
// Welding: the triangles of a mesh over its distinct positions. Formats repeat positions (STL
// stores every corner of every triangle; glTF splits vertices at UV and normal seams; OBJ files
// may list a position twice), and connectivity, the basis of every topology count, is about
// where the corners are, not how the file numbered them. Positions are merged when they are
// exactly equal (−0 and +0 are the same point); no tolerance, so nothing that is apart in the
// file is joined here.

#include <array>
#include <cstdint>
#include <vector>

#include "engine/geometry/mesh.h"

namespace raycastd::engine {

/// A mesh's triangles over welded vertex ids.
struct WeldedTriangles {
    /// triangles[i] is mesh triangle i over welded ids (file order kept).
    std::vector<std::array<std::uint32_t, 3>> triangles;
    /// Distinct positions the triangles use; ids run 0 .. vertices−1 in order of first use.
    std::uint32_t vertices = 0;
};

/// Welds the positions the triangles use (unused positions get no id); one hash-table pass over
/// the corners, O(triangles).
WeldedTriangles weld(const TriangleMesh& mesh);

}  // namespace raycastd::engine
