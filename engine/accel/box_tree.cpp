#include "engine/accel/box_tree.h"

#include <algorithm>
#include <numeric>

namespace raycastd::engine {

BoxTree::BoxTree(const std::vector<Bounds3>& boxes) {
    // Empty boxes (a component without corners cannot occur, but the type allows it) hold no
    // point; they are left out rather than given a node.
    for (std::uint32_t i = 0; i < boxes.size(); ++i) {
        if (!boxes[i].empty()) {
            items_.push_back(i);
            boxes_.push_back(boxes[i]);
        }
    }
    if (items_.empty())
        return;
    nodes_.reserve(2 * (items_.size() / kLeaf + 1));
    nodes_.emplace_back();
    build(0, 0, static_cast<std::uint32_t>(items_.size()));
}

void BoxTree::build(std::uint32_t node, std::uint32_t first, std::uint32_t count) {
    Bounds3 box, centres;
    for (std::uint32_t k = first; k < first + count; ++k) {
        box.extend(boxes_[k]);
        centres.extend(boxes_[k].center());
    }
    nodes_[node].box = box;
    const Vec3d e = centres.diagonal();
    if (count <= kLeaf || (e.x == 0 && e.y == 0 && e.z == 0)) {
        // A leaf; boxes with one centre cannot be split by it (their count is rarely large).
        nodes_[node].first = first;
        nodes_[node].count = count;
        return;
    }
    const int axis = e.x >= e.y && e.x >= e.z ? 0 : (e.y >= e.z ? 1 : 2);
    auto key = [axis](const Bounds3& b) {
        const Vec3d c = b.center();
        return axis == 0 ? c.x : (axis == 1 ? c.y : c.z);
    };
    // Sort the range's (box, item) pairs around the median centre.
    std::vector<std::uint32_t> idx(count);
    std::iota(idx.begin(), idx.end(), first);
    const std::uint32_t half = count / 2;
    std::nth_element(
        idx.begin(), idx.begin() + half, idx.end(),
        [&](std::uint32_t a, std::uint32_t b) { return key(boxes_[a]) < key(boxes_[b]); });
    std::vector<Bounds3> b(count);
    std::vector<std::uint32_t> it(count);
    for (std::uint32_t k = 0; k < count; ++k) {
        b[k] = boxes_[idx[k]];
        it[k] = items_[idx[k]];
    }
    std::copy(b.begin(), b.end(), boxes_.begin() + first);
    std::copy(it.begin(), it.end(), items_.begin() + first);
    const auto left = static_cast<std::uint32_t>(nodes_.size());
    nodes_.emplace_back();
    nodes_.emplace_back();
    nodes_[node].first = left;
    nodes_[node].count = 0;
    build(left, first, half);
    build(left + 1, first + half, count - half);
}

}  // namespace raycastd::engine
