#pragma once
// What the crossing-parity test of engine/points/inside.cpp works with: the connected components
// of each parity mesh (mesh/components.h says why a component whose box does not hold a point
// can be left out of that point's count) and one BoxGrid of their boxes over the whole scene, so
// that a point asks the grid, not every object, which pieces can hold it. QueryEngine builds them
// on the first query that reaches the parity test (point_entry.cpp): a scene never asked for a
// signed distance or an occupancy does not pay for them.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "engine/accel/box_grid.h"
#include "engine/mesh/components.h"

namespace raycastd::engine {

struct ParityPieces {
    /// The components of each parity mesh; an empty entry for every other object.
    std::vector<MeshComponents> of_object;
    /// The piece number of object o's component 0 (o's component c is piece first[o] + c).
    std::vector<std::uint32_t> first;
    /// The object of each piece.
    std::vector<std::uint32_t> object;
    /// Over the pieces' boxes (their components'): which of them hold a point.
    BoxGrid grid;
    /// Each piece's box widened for the end of a parity ray, once at build: by 2⁻²⁰ of its
    /// largest extent plus 2⁻⁴⁰ of its largest coordinate. Every crossing of a piece lies in its
    /// box, so at most the unwidened exit away, and the widening is over 2¹⁰ times what the exact
    /// path's rounding of a t can move it (a few ulps of the coordinates): a ray that ends where
    /// it leaves these loses none of those crossings at its far end, and its end is outside every
    /// piece's box it was cast for, which is all mesh/components.h asks of it. (The coordinates'
    /// share is kept small: a small component far from the origin would otherwise get a ray many
    /// times its size.)
    std::vector<Bounds3> ray_bounds;

    /// The piece of triangle `primitive` of parity mesh `o`.
    std::uint32_t piece(std::uint32_t o, std::uint32_t primitive) const {
        return first[o] + of_object[o].component(primitive);
    }
    std::size_t memory_bytes() const;
};

}  // namespace raycastd::engine
