#include "engine/accel/box_grid.h"

#include <algorithm>
#include <cmath>

namespace raycastd::engine {

namespace {

/// Cells a box on average (the grid's resolution), the entries a box at most before the grid is
/// made coarser, and the most cells (4M: 16 MB of cell starts) whatever the count of boxes (the
/// axes' counts are rounded up, then halved until their product is within it).
constexpr double kCellsPerBox = 8.0;
constexpr std::size_t kMaxEntriesPerBox = 64;
constexpr double kMaxCells = 4194304.0;

}  // namespace

BoxGrid::BoxGrid(const std::vector<Bounds3>& boxes) : boxes_(boxes) {
    std::size_t live = 0;
    for (const Bounds3& b : boxes_) {
        if (!b.empty()) {
            union_.extend(b);
            ++live;
        }
    }
    if (live == 0)
        return;
    const Vec3d e = union_.diagonal();
    const double ext[3] = {e.x, e.y, e.z};
    // A cell side s with Π (extent_a / s) ≈ the cells wanted, in units of the largest extent (so
    // that neither tiny nor huge coordinates underflow or overflow the volume); an axis the
    // boxes do not spread along (a flat or a linear layout) counts as a thousandth of it.
    const double largest = std::max({e.x, e.y, e.z});
    const double want = std::min(kCellsPerBox * static_cast<double>(live), kMaxCells);
    double rel_volume = 1.0;
    for (double x : ext)
        rel_volume *= largest > 0 ? std::max(x / largest, 1e-3) : 1.0;
    const double rel_side = std::cbrt(rel_volume / want);  // in [1e-2 / want^⅓, 1]
    for (int a = 0; a < 3; ++a) {
        origin_[a] = a == 0 ? union_.lo.x : (a == 1 ? union_.lo.y : union_.lo.z);
        // Cells along the axis; 1 where the quotient is not a number ≥ 1 (a zero or an overflowed
        // extent: largest = inf gives inf / inf).
        const double cells_a = largest > 0 ? std::ceil(ext[a] / largest / rel_side) : 1.0;
        res_[a] = cells_a >= 1.0 ? static_cast<std::size_t>(std::min(cells_a, 4096.0)) : 1;
    }
    while (static_cast<double>(cells()) > kMaxCells) {
        for (std::size_t& r : res_)
            r = (r + 1) / 2;
    }
    // Coarser while the boxes would be entered too often (large or piled-up boxes).
    std::vector<std::size_t> range;  // per box and axis: first and last cell
    for (;;) {
        for (int a = 0; a < 3; ++a) {
            // A finite, positive scale, or 0 (every point in cell 0 along that axis).
            const double sc = static_cast<double>(res_[a]) / ext[a];
            scale_[a] = ext[a] > 0 && std::isfinite(sc) ? sc : 0.0;
        }
        range.assign(boxes_.size() * 6, 0);
        std::size_t entries = 0;
        for (std::size_t i = 0; i < boxes_.size(); ++i) {
            const Bounds3& b = boxes_[i];
            if (b.empty())
                continue;
            std::size_t* r = &range[6 * i];
            r[0] = cell(b.lo.x, 0), r[1] = cell(b.hi.x, 0);
            r[2] = cell(b.lo.y, 1), r[3] = cell(b.hi.y, 1);
            r[4] = cell(b.lo.z, 2), r[5] = cell(b.hi.z, 2);
            entries += (r[1] - r[0] + 1) * (r[3] - r[2] + 1) * (r[5] - r[4] + 1);
        }
        if (entries <= kMaxEntriesPerBox * live || cells() == 1)
            break;
        for (std::size_t& r : res_)
            r = (r + 1) / 2;
    }
    // The CSR table: counts, starts, then the boxes in increasing index within each cell.
    start_.assign(cells() + 1, 0);
    auto for_cells = [&](std::size_t i, auto&& f) {
        const std::size_t* r = &range[6 * i];
        for (std::size_t z = r[4]; z <= r[5]; ++z)
            for (std::size_t y = r[2]; y <= r[3]; ++y)
                for (std::size_t x = r[0]; x <= r[1]; ++x)
                    f(x + res_[0] * (y + res_[1] * z));
    };
    for (std::size_t i = 0; i < boxes_.size(); ++i) {
        if (!boxes_[i].empty())
            for_cells(i, [&](std::size_t c) { ++start_[c + 1]; });
    }
    for (std::size_t c = 0; c < cells(); ++c)
        start_[c + 1] += start_[c];
    entries_.resize(start_.back());
    std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < boxes_.size(); ++i) {
        if (!boxes_[i].empty())
            for_cells(i,
                      [&](std::size_t c) { entries_[fill[c]++] = static_cast<std::uint32_t>(i); });
    }
}

}  // namespace raycastd::engine
