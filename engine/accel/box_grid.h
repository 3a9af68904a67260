#pragma once
// BoxGrid: which of a fixed set of boxes hold a point (a stabbing query), for the parity test's
// component boxes (mesh/components.h; engine/points/inside.cpp asks once per point).
//
// A uniform grid over the boxes' union, each cell listing the boxes that overlap it (a CSR
// table). A query finds its cell with one floor per axis and tests that cell's boxes exactly.
// Why a grid and not a tree: a binary tree of the 200 component boxes of bench_points' scene B
// took 300 ns a query on B's shell points (its upper nodes overlap, so a query descends into
// many), the grid 133 ns in the same driver (both with each point's own cache miss: the points
// read in spatial order from an array in random order), and 20 ns on points already in order.
//
// Exactness: a box is entered in the cells c(lo) .. c(hi) of each axis, c(x) =
// floor((x − origin)·scale) clamped to the grid, and a point is looked up in cell c(p) with the
// same function. c is monotone in x (a rounded subtraction and a rounded product by a positive
// number never reverse an order), so lo ≤ p ≤ hi gives c(lo) ≤ c(p) ≤ c(hi): the box is listed
// in the point's cell. Points outside the union hold no box and are answered before any cell.
//
// Size: about 8 cells a box, over the union's axes in proportion to its extents; where boxes
// are so large or so piled up that the entries would pass 64 a box, the grid is made coarser
// (down to one cell: a scan of every box, the cost such input has with any method that lists
// all the boxes holding a point, as nested shells make it).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "engine/math/bounds.h"

namespace raycastd::engine {

class BoxGrid {
  public:
    BoxGrid() = default;
    explicit BoxGrid(const std::vector<Bounds3>& boxes);

    /// Calls f(i) for each box i that holds p (lo ≤ p ≤ hi on every axis), in increasing i.
    template <class F>
    void containing(const Vec3d& p, F&& f) const {
        if (!holds(union_, p))
            return;
        const std::size_t c = cell(p.x, 0) + res_[0] * (cell(p.y, 1) + res_[1] * cell(p.z, 2));
        for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
            const std::uint32_t i = entries_[k];
            if (holds(boxes_[i], p))
                f(i);
        }
    }
    std::size_t size() const { return boxes_.size(); }
    /// Cells along x, y, z (for tests: the coarsening of piled-up boxes).
    std::size_t cells() const { return res_[0] * res_[1] * res_[2]; }
    std::size_t memory_bytes() const {
        return boxes_.capacity() * sizeof(Bounds3) +
               (start_.capacity() + entries_.capacity()) * sizeof(std::uint32_t);
    }

  private:
    static bool holds(const Bounds3& b, const Vec3d& p) {
        return b.lo.x <= p.x && p.x <= b.hi.x && b.lo.y <= p.y && p.y <= b.hi.y && b.lo.z <= p.z &&
               p.z <= b.hi.z;
    }
    /// c(x) of the file comment along `axis`.
    std::size_t cell(double x, int axis) const {
        const double c = (x - origin_[axis]) * scale_[axis];
        if (!(c > 0.0))
            return 0;  // below the origin, or NaN (never asked: points are finite)
        const double top = static_cast<double>(res_[axis] - 1);
        return static_cast<std::size_t>(c < top ? c : top);
    }

    std::vector<Bounds3> boxes_;
    Bounds3 union_;
    double origin_[3] = {0, 0, 0};
    double scale_[3] = {0, 0, 0};  ///< cells per unit length
    std::size_t res_[3] = {1, 1, 1};
    std::vector<std::uint32_t> start_ = {0, 0};  ///< cell c's entries: [start_[c], start_[c+1])
    std::vector<std::uint32_t> entries_;         ///< box indices, increasing within a cell
};

}  // namespace raycastd::engine
