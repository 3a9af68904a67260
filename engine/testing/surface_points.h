#pragma once
// Sampling a mesh's surface, for the tests and benchmarks that put points on or near it
// (bench_points' shell of B, points_accuracy's field shell).

#include <cmath>

#include "engine/math/vec3.h"

namespace raycastd::engine::testing {

/// The point of triangle (a, b, c) for r1, r2 uniform in [0, 1): uniform over its area,
/// (1 − √r₁) a + √r₁(1 − r₂) b + √r₁ r₂ c (Osada, Funkhouser, Chazelle & Dobkin 2002, §4.2).
inline Vec3d uniform_on_triangle(const Vec3d& a, const Vec3d& b, const Vec3d& c, double r1,
                                 double r2) {
    const double s1 = std::sqrt(r1);
    return a * (1.0 - s1) + b * (s1 * (1.0 - r2)) + c * (s1 * r2);
}

}  // namespace raycastd::engine::testing
