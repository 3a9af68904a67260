#pragma once
// The point-query tests' comparison: two answers are the same winner with the same bits.

#include <optional>

#include <gtest/gtest.h>

#include "engine/geometry/closest_point.h"

namespace raycastd::engine::testing {

/// Both nullopt, or the same object, primitive, distance, point and normal, bit for bit.
inline void expect_same_point_hit(const std::optional<PointHit>& a,
                                  const std::optional<PointHit>& b) {
    ASSERT_EQ(a.has_value(), b.has_value());
    if (!a)
        return;
    EXPECT_EQ(a->object, b->object);
    EXPECT_EQ(a->primitive, b->primitive);
    EXPECT_EQ(a->distance, b->distance);
    EXPECT_EQ(a->point, b->point);
    EXPECT_EQ(a->normal, b->normal);
}

}  // namespace raycastd::engine::testing
