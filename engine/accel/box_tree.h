#pragma once
// BoxTree: which of a fixed set of boxes hold a point (a stabbing query), for the parity test's
// component boxes (mesh/components.h; engine/points/inside.cpp asks once per point).
//
// A binary tree of the boxes by median split of their centres along the longest axis of the
// centres' extent, leaves of at most kLeaf boxes; a node's box is the union of its boxes', and a
// query descends only into nodes whose box holds the point. Boxes that overlap little (separate
// objects, the spheres of bench_points' scene B) cost O(log n) a query; nested ones (a hollow
// shell's two surfaces) are all reported, as they must be. Tests are exact comparisons of
// coordinates, closed on both sides: a point on a box's face is in the box.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "engine/math/bounds.h"

namespace raycastd::engine {

class BoxTree {
  public:
    BoxTree() = default;
    explicit BoxTree(const std::vector<Bounds3>& boxes);

    /// Calls f(i) for each box i that holds p (lo ≤ p ≤ hi on every axis), in no set order.
    template <class F>
    void containing(const Vec3d& p, F&& f) const {
        if (nodes_.empty())
            return;
        std::uint32_t stack[64];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const Node& n = nodes_[stack[--top]];
            if (!holds(n.box, p))
                continue;
            if (n.count == 0) {
                // Depth ≤ log2(n / kLeaf) + 1 < 32 for any count of boxes a uint32 numbers.
                stack[top++] = n.first;
                stack[top++] = n.first + 1;
                continue;
            }
            for (std::uint32_t k = n.first; k < n.first + n.count; ++k) {
                if (holds(boxes_[k], p))
                    f(items_[k]);
            }
        }
    }
    std::size_t size() const { return items_.size(); }
    std::size_t memory_bytes() const {
        return nodes_.capacity() * sizeof(Node) + boxes_.capacity() * sizeof(Bounds3) +
               items_.capacity() * sizeof(std::uint32_t);
    }

  private:
    static constexpr std::uint32_t kLeaf = 4;
    /// count == 0: an inner node, children at first and first + 1; else a leaf of boxes_[first,
    /// first + count).
    struct Node {
        Bounds3 box;
        std::uint32_t first = 0;
        std::uint32_t count = 0;
    };
    static bool holds(const Bounds3& b, const Vec3d& p) {
        return b.lo.x <= p.x && p.x <= b.hi.x && b.lo.y <= p.y && p.y <= b.hi.y && b.lo.z <= p.z &&
               p.z <= b.hi.z;
    }
    void build(std::uint32_t node, std::uint32_t first, std::uint32_t count);

    std::vector<Node> nodes_;
    std::vector<Bounds3> boxes_;        ///< in leaf order
    std::vector<std::uint32_t> items_;  ///< each leaf-order box's index in the constructor's list
};

}  // namespace raycastd::engine
