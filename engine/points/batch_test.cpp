// The spatial order of a batch: a permutation, near points next to each other, and answers that
// do not depend on it.

#include "engine/points/batch.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include "engine/points/inside.h"
#include "engine/points/point_queries.h"
#include "engine/testing/point_meshes.h"
#include "engine/testing/scenes.h"

namespace raycastd::engine {
namespace {

std::vector<Vec3d> uniform_points(std::size_t n, std::uint64_t seed, double half = 1.5) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-half, half);
    std::vector<Vec3d> out(n);
    for (Vec3d& p : out)
        p = {u(rng), u(rng), u(rng)};
    return out;
}

double path_length(const std::vector<Vec3d>& pts, const std::vector<std::uint32_t>& order) {
    double sum = 0;
    for (std::size_t k = 1; k < order.size(); ++k)
        sum += length(pts[order[k]] - pts[order[k - 1]]);
    return sum;
}

/// order holds each of 0 .. n−1 once.
void expect_permutation(const std::vector<std::uint32_t>& order, std::size_t n) {
    ASSERT_EQ(order.size(), n);
    std::vector<std::uint32_t> sorted = order;
    std::sort(sorted.begin(), sorted.end());
    for (std::uint32_t i = 0; i < sorted.size(); ++i)
        ASSERT_EQ(sorted[i], i);
}

TEST(SpatialOrder, SmallBatchesKeepTheirOrder) {
    const auto pts = uniform_points(kSpatialOrderMin - 1, 1);
    EXPECT_TRUE(spatial_order(pts.data(), pts.size()).empty());
    // Bounds of no extent: nothing to order by.
    const std::vector<Vec3d> same(2 * kSpatialOrderMin, Vec3d{1, 2, 3});
    EXPECT_TRUE(spatial_order(same.data(), same.size()).empty());
}

TEST(SpatialOrder, IsAPermutationWithNearPointsTogetherAndTheNonFiniteFirst) {
    std::vector<Vec3d> pts = uniform_points(100'000, 2);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    pts[500] = {nan, 0, 0};
    pts[70'000] = {0, std::numeric_limits<double>::infinity(), 0};
    pts[99'999] = {1e300, -1e300, 0};  // finite, far: stretches the grid, still ordered
    const std::vector<std::uint32_t> order = spatial_order(pts.data(), pts.size());
    ASSERT_NO_FATAL_FAILURE(expect_permutation(order, pts.size()));
    EXPECT_EQ(order[0], 500u);  // the non-finite, in their own order
    EXPECT_EQ(order[1], 70'000u);

    // Without the far point, the walk through the points in this order is a small fraction of
    // the walk in the given order (a random order: about 1.9 a step; a Z-order of 64³ cells over
    // 10⁵ points: well under a tenth of it).
    pts.resize(99'990);
    pts[500] = pts[70'000] = {0, 0, 0};
    std::vector<std::uint32_t> given(pts.size());
    for (std::uint32_t i = 0; i < given.size(); ++i)
        given[i] = i;
    const std::vector<std::uint32_t> z = spatial_order(pts.data(), pts.size());
    const double ratio = path_length(pts, z) / path_length(pts, given);
    std::printf("Z-order path / given path: %.4f\n", ratio);
    EXPECT_LT(ratio, 0.1);
}

TEST(SpatialOrder, ExtentsTooSmallOrTooLargeForTheirCellsStillGiveAPermutation) {
    // x spans a subnormal extent (64 / extent overflows: that axis gets one cell), z spans 1e308
    // (near overflow); y orders the points.
    const double tiny = std::numeric_limits<double>::denorm_min();
    std::vector<Vec3d> pts = uniform_points(4 * kSpatialOrderMin, 3);
    for (std::size_t i = 0; i < pts.size(); ++i) {
        pts[i].x = i % 2 ? tiny : 0.0;
        pts[i].z = i % 3 ? 1e308 : -1e307;
    }
    const std::vector<std::uint32_t> order = spatial_order(pts.data(), pts.size());
    ASSERT_NO_FATAL_FAILURE(expect_permutation(order, pts.size()));
    // Within one z slab (the same z), y never decreases by more than a cell's height: 16,384
    // points get 2⁵ cells an axis, y's extent is 3.
    double last_y = -kInfinity, last_z = pts[order[0]].z;
    std::size_t out_of_order = 0;
    for (std::uint32_t i : order) {
        if (pts[i].z != last_z) {
            last_z = pts[i].z;
            last_y = -kInfinity;
        }
        out_of_order += !(pts[i].y > last_y - 3.0 / 32 * 1.01);
        last_y = std::max(last_y, pts[i].y);
    }
    EXPECT_EQ(out_of_order, 0u);
}

TEST(SpatialOrder, ForEachPointVisitsEachIndexOnceInTheGivenOrder) {
    const std::size_t n = 10'000;
    const auto pts = uniform_points(n, 3);
    const std::vector<std::uint32_t> order = spatial_order(pts.data(), n);
    std::vector<std::atomic<int>> seen(n);
    for_each_point(n, CancelToken{}, order, [&](std::size_t i) { ++seen[i]; });
    for (std::size_t i = 0; i < n; ++i)
        ASSERT_EQ(seen[i].load(), 1) << i;
    // On one thread the blocks run one after the other, first to last: exactly `order`.
    std::vector<std::size_t> visits;
    tbb::task_arena(1).execute([&] {
        for_each_point(n, CancelToken{}, order, [&](std::size_t i) { visits.push_back(i); });
    });
    ASSERT_EQ(visits.size(), n);
    for (std::size_t k = 0; k < n; ++k)
        ASSERT_EQ(visits[k], order[k]) << k;
}

// The Z-order itself: 16³ points at the centres of the cells of a 16³ grid (and two corners),
// shuffled, come out in the order of their Morton codes with x in the lowest bit (Morton 1966),
// the code computed here bit by bit from the cell. spatial_order's grid for 4,098 points has 32
// cells an axis: each point is then in cell 2x + 1, whose 5-bit code is the 4-bit one shifted
// up by three bits (the finer Z-order nests in the coarser), so the order is the same.
TEST(SpatialOrder, CellsComeInMortonOrderWithXLowest) {
    std::vector<Vec3d> pts;
    std::vector<std::uint32_t> code;
    for (std::uint32_t z = 0; z < 16; ++z) {
        for (std::uint32_t y = 0; y < 16; ++y) {
            for (std::uint32_t x = 0; x < 16; ++x) {
                pts.push_back({x + 0.5, y + 0.5, z + 0.5});
                std::uint32_t c = 0;
                for (int b = 0; b < 4; ++b)
                    c |= (((x >> b) & 1u) << (3 * b)) | (((y >> b) & 1u) << (3 * b + 1)) |
                         (((z >> b) & 1u) << (3 * b + 2));
                code.push_back(c);
            }
        }
    }
    // Stretch the bounds to exactly [0, 16]³ so that each point sits in the middle of its cell.
    pts.push_back({0, 0, 0});
    code.push_back(0);
    pts.push_back({16, 16, 16});
    code.push_back(4095);  // on the upper face: clamped into the last cell
    std::vector<std::size_t> shuffle(pts.size());
    for (std::size_t i = 0; i < shuffle.size(); ++i)
        shuffle[i] = i;
    std::shuffle(shuffle.begin(), shuffle.end(), std::mt19937_64(5));
    std::vector<Vec3d> shuffled;
    std::vector<std::uint32_t> shuffled_code;
    for (std::size_t i : shuffle) {
        shuffled.push_back(pts[i]);
        shuffled_code.push_back(code[i]);
    }
    const std::vector<std::uint32_t> order = spatial_order(shuffled.data(), shuffled.size());
    ASSERT_EQ(order.size(), shuffled.size());
    for (std::size_t k = 1; k < order.size(); ++k)
        ASSERT_LE(shuffled_code[order[k - 1]], shuffled_code[order[k]]) << k;
}

// Every answer of a batch taken in its spatial order is the one the point gets alone: the
// closest point bit for bit, the sign and the winding number.
TEST(SpatialOrder, BatchAnswersAreThePointsOwn) {
    const Scene scene = testing::scene_of({testing::icosphere_object(3, {0.1, 0, 0}, 1.0),
                                           testing::sphere("ball", {1.2, 0.3, 0}, 0.4, 0)});
    auto built = QueryEngine::build(std::make_shared<Scene>(scene));
    ASSERT_TRUE(built.ok());
    const QueryEngine& engine = **built;
    const auto pts = uniform_points(2 * kSpatialOrderMin, 4);
    ASSERT_FALSE(spatial_order(pts.data(), pts.size()).empty());
    std::vector<PointAnswer> batch;
    ASSERT_TRUE(
        query_points(engine, pts, PointOptions{PointQuery::occupancy, kInfinity, {}}, batch).ok());
    std::size_t wrong = 0, inside = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
        std::vector<PointAnswer> one;
        ASSERT_TRUE(
            query_points(engine, {pts[i]}, PointOptions{PointQuery::occupancy, kInfinity, {}}, one)
                .ok());
        const PointAnswer &a = batch[i], &b = one[0];
        wrong += a.hit.distance != b.hit.distance || a.hit.object != b.hit.object ||
                 a.hit.primitive != b.hit.primitive || !(a.hit.point == b.hit.point) ||
                 a.inside != b.inside || a.winding != b.winding;
        inside += a.inside;
    }
    EXPECT_EQ(wrong, 0u);
    EXPECT_GT(inside, 100u);
}

}  // namespace
}  // namespace raycastd::engine
