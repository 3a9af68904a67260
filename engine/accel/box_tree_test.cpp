#include "engine/accel/box_tree.h"

#include <algorithm>
#include <random>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

std::vector<std::uint32_t> found(const BoxTree& t, const Vec3d& p) {
    std::vector<std::uint32_t> out;
    t.containing(p, [&](std::uint32_t i) { out.push_back(i); });
    std::sort(out.begin(), out.end());
    return out;
}

TEST(BoxTree, FindsWhatAScanOfEveryBoxFinds) {
    // Boxes of all sizes, many overlapping and some nested, and points on their faces and
    // corners as well as anywhere: the tree must report exactly the boxes a scan reports.
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-10, 10), s(0, 3);
    for (std::size_t n : {0u, 1u, 3u, 4u, 5u, 17u, 200u, 1000u}) {
        std::vector<Bounds3> boxes(n);
        for (auto& b : boxes) {
            const Vec3d c{u(rng), u(rng), u(rng)};
            const Vec3d h{s(rng), s(rng), s(rng)};
            b.lo = c - h;
            b.hi = c + h;
        }
        const BoxTree tree(boxes);
        EXPECT_EQ(tree.size(), n);
        for (int q = 0; q < 2000; ++q) {
            Vec3d p{u(rng), u(rng), u(rng)};
            if (n > 0 && q % 4 == 0) {
                const Bounds3& b = boxes[rng() % n];  // a corner or a face of some box
                p = {q % 8 == 0 ? b.lo.x : b.hi.x, b.hi.y, q % 16 == 0 ? p.z : b.lo.z};
            }
            std::vector<std::uint32_t> want;
            for (std::uint32_t i = 0; i < n; ++i) {
                const Bounds3& b = boxes[i];
                if (b.lo.x <= p.x && p.x <= b.hi.x && b.lo.y <= p.y && p.y <= b.hi.y &&
                    b.lo.z <= p.z && p.z <= b.hi.z)
                    want.push_back(i);
            }
            ASSERT_EQ(found(tree, p), want) << n << " boxes, query " << q;
        }
    }
}

TEST(BoxTree, ManyBoxesWithOneCentreAndEmptyBoxes) {
    // Nested boxes about one centre cannot be split by their centres: one leaf holds them all.
    std::vector<Bounds3> boxes;
    for (int k = 1; k <= 40; ++k)
        boxes.push_back(
            Bounds3{{-double(k), -double(k), -double(k)}, {double(k), double(k), double(k)}});
    boxes.push_back(Bounds3{});  // empty: holds nothing
    const BoxTree tree(boxes);
    EXPECT_EQ(tree.size(), 40u);
    EXPECT_EQ(found(tree, {0, 0, 0}).size(), 40u);
    EXPECT_EQ(found(tree, {0, 0, 39.5}), (std::vector<std::uint32_t>{39}));
    EXPECT_TRUE(found(tree, {0, 0, 41}).empty());
}

}  // namespace
}  // namespace raycastd::engine
