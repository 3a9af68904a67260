#pragma once
// Mirror reflection and Snell refraction of a ray direction (Whitted 1980, §2; the vector forms
// are those of pbrt-v4 §9.3 and §9.5).

#include <algorithm>
#include <cmath>
#include <optional>

#include "engine/math/vec3.h"

namespace raycastd::engine {

/// The mirror direction of `d` about the unit normal `n`: r = d − 2(d·n)n. Either side of `n`
/// gives the same r; |r| = |d|.
inline Vec3d reflect(const Vec3d& d, const Vec3d& n) {
    return d - n * (2.0 * dot(d, n));
}

/// Snell's law η₁ sin θ₁ = η₂ sin θ₂ for the unit direction `d` arriving at a surface with unit
/// normal `n` facing the arriving ray (d·n ≤ 0), with eta = η₁/η₂ (outside over inside when
/// entering). Returns the unit transmitted direction
///   t = η·d + (η·cos θ₁ − cos θ₂)·n,  cos θ₂ = √(1 − η²(1 − cos² θ₁)),
/// or nullopt on total internal reflection (η² sin² θ₁ > 1), when no light is transmitted.
inline std::optional<Vec3d> refract(const Vec3d& d, const Vec3d& n, double eta) {
    const double cos_i = std::min(1.0, -dot(d, n));
    const double sin2_t = eta * eta * std::max(0.0, 1.0 - cos_i * cos_i);
    if (sin2_t > 1.0)
        return std::nullopt;
    const double cos_t = std::sqrt(1.0 - sin2_t);
    return normalize(d * eta + n * (eta * cos_i - cos_t));
}

/// `n` turned to the side the ray with direction `d` arrives from (so that d·n ≤ 0).
inline Vec3d face_towards_ray(const Vec3d& n, const Vec3d& d) {
    return dot(n, d) > 0.0 ? -n : n;
}

}  // namespace raycastd::engine
