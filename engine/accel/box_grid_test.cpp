#include "engine/accel/box_grid.h"

#include <algorithm>
#include <random>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

std::vector<std::uint32_t> found(const BoxGrid& g, const Vec3d& p) {
    std::vector<std::uint32_t> out;
    g.containing(p, [&](std::uint32_t i) { out.push_back(i); });
    return out;  // increasing, as containing promises: compared as it comes
}

std::vector<std::uint32_t> scan(const std::vector<Bounds3>& boxes, const Vec3d& p) {
    std::vector<std::uint32_t> want;
    for (std::uint32_t i = 0; i < boxes.size(); ++i) {
        const Bounds3& b = boxes[i];
        if (b.lo.x <= p.x && p.x <= b.hi.x && b.lo.y <= p.y && p.y <= b.hi.y && b.lo.z <= p.z &&
            p.z <= b.hi.z)
            want.push_back(i);
    }
    return want;
}

TEST(BoxGrid, FindsWhatAScanOfEveryBoxFinds) {
    // Boxes of all sizes, many overlapping and some nested, and points on their faces and
    // corners (where a rounded cell index could miss the box) as well as anywhere.
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
        const BoxGrid grid(boxes);
        EXPECT_EQ(grid.size(), n);
        for (int q = 0; q < 4000; ++q) {
            Vec3d p{u(rng), u(rng), u(rng)};
            if (n > 0 && q % 2 == 0) {
                const Bounds3& b = boxes[rng() % n];  // a corner, an edge or a face of some box
                p = {q % 4 == 0 ? b.lo.x : b.hi.x, q % 8 < 4 ? b.hi.y : b.lo.y,
                     q % 16 == 0 ? p.z : b.lo.z};
            }
            ASSERT_EQ(found(grid, p), scan(boxes, p)) << n << " boxes, query " << q;
        }
    }
}

TEST(BoxGrid, FlatLayoutsAndAwkwardCoordinates) {
    // Boxes in one plane (the grid has one cell across it), boxes of zero thickness, and
    // coordinates whose differences round: the point on a face is still found.
    std::vector<Bounds3> boxes;
    for (int k = 0; k < 50; ++k) {
        const double x = 0.1 * k + 1e8;
        boxes.push_back(Bounds3{{x, 0.3, 7}, {x + 0.1, 0.7, 7}});
    }
    const BoxGrid grid(boxes);
    for (int k = 0; k < 50; ++k) {
        const Vec3d on_face{boxes[k].hi.x, 0.5, 7};
        EXPECT_EQ(found(grid, on_face), scan(boxes, on_face)) << k;
        const Vec3d corner{boxes[k].lo.x, 0.3, 7};
        EXPECT_EQ(found(grid, corner), scan(boxes, corner)) << k;
    }
    EXPECT_TRUE(found(grid, {1e8 + 1, 0.5, 7.000001}).empty());  // outside the union
    // Inside the union, between two boxes in y: in no box.
    EXPECT_TRUE(found(grid, {boxes[3].lo.x + 0.05, 0.2, 7}).empty());
    EXPECT_EQ(found(grid, {boxes[3].lo.x + 0.05, 0.3, 7}), (std::vector<std::uint32_t>{3}));
}

TEST(BoxGrid, TinyAndHugeCoordinates) {
    // A union of 1e-200 across (its volume underflows) and one of 1e308 (its extent overflows):
    // the grid stays small and answers as a scan does.
    for (double unit : {1e-200, 3e307}) {
        std::vector<Bounds3> boxes;
        for (int k = -5; k < 5; ++k)
            boxes.push_back(Bounds3{{k * unit, -unit, 0}, {(k + 0.5) * unit, unit, unit}});
        const BoxGrid grid(boxes);
        EXPECT_LE(grid.cells(), 4096u * 1024);
        for (int k = -5; k < 5; ++k) {
            for (const Vec3d& p : {Vec3d{k * unit, 0, 0}, Vec3d{(k + 0.25) * unit, unit, unit},
                                   Vec3d{(k + 0.75) * unit, 0, 0}})
                EXPECT_EQ(found(grid, p), scan(boxes, p)) << unit << " " << k;
        }
    }
}

TEST(BoxGrid, PiledUpBoxesMakeItCoarser) {
    // Nested boxes about one centre overlap every cell a fine grid would have: the grid is made
    // coarser (15³ cells at first, then 8³, then 4³ where the entries are within 64 a box)
    // rather than listing each box thousands of times.
    std::vector<Bounds3> boxes;
    for (int k = 1; k <= 400; ++k) {
        const double r = k;
        boxes.push_back(Bounds3{{-r, -r, -r}, {r, r, r}});
    }
    boxes.push_back(Bounds3{});  // empty: holds nothing
    const BoxGrid grid(boxes);
    EXPECT_EQ(grid.cells(), 64u);
    EXPECT_LT(grid.memory_bytes(), 400u * 64 * 4 + 401 * sizeof(Bounds3) + 1024);
    EXPECT_EQ(found(grid, {0, 0, 0}).size(), 400u);
    EXPECT_EQ(found(grid, {0, 0, 399.5}), (std::vector<std::uint32_t>{399}));
    EXPECT_TRUE(found(grid, {0, 0, 401}).empty());
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(-410, 410);
    for (int q = 0; q < 500; ++q) {
        const Vec3d p{u(rng), u(rng), u(rng)};
        ASSERT_EQ(found(grid, p), scan(boxes, p));
    }
}

TEST(BoxGrid, NoBoxes) {
    EXPECT_TRUE(found(BoxGrid(std::vector<Bounds3>{}), {0, 0, 0}).empty());
    EXPECT_TRUE(found(BoxGrid(std::vector<Bounds3>{Bounds3{}}), {0, 0, 0}).empty());
    EXPECT_TRUE(found(BoxGrid{}, {0, 0, 0}).empty());
}

}  // namespace
}  // namespace raycastd::engine
