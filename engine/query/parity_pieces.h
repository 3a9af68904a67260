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
    /// The box of each piece (its component's).
    std::vector<Bounds3> bounds;
    /// Over `bounds`: which pieces' boxes hold a point.
    BoxGrid grid;

    /// The piece of triangle `primitive` of parity mesh `o`.
    std::uint32_t piece(std::uint32_t o, std::uint32_t primitive) const {
        return first[o] + of_object[o].component(primitive);
    }
    std::size_t memory_bytes() const;
};

}  // namespace raycastd::engine
