#pragma once
// The solid angle a triangle subtends at a point, for generalized winding numbers.
//
// Van Oosterom & Strackee, "The Solid Angle of a Plane Triangle", IEEE Trans. Biomed. Eng. 30(2),
// 1983: with a, b, c the corners relative to the point and |a|, |b|, |c| their lengths,
//   tan(Ω/2) = a·(b × c) / (|a||b||c| + (a·b)|c| + (b·c)|a| + (c·a)|b|),
// evaluated with atan2, which keeps the quadrant (Ω in (−2π, 2π]). Ω > 0 when the point sees the
// triangle's back (the side opposite (b−a)×(c−a)): inside a closed, outward-facing mesh the solid
// angles sum to 4π. The generalized winding number (Jacobson, Kavan & Sorkine-Hornung, "Robust
// Inside-Outside Segmentation using Generalized Winding Numbers", SIGGRAPH 2013) is Σ Ω / 4π.
// A point in the triangle's plane gets 0 outside it and ±2π inside it (the sign of a zero);
// points on surfaces are decided before any winding number is asked for (engine/points).

#include <cmath>

#include "engine/geometry/triangle.h"

namespace raycastd::engine {

/// The signed solid angle of `tri` seen from q, in steradians (see the file comment).
inline double triangle_solid_angle(const Triangle& tri, const Vec3d& q) {
    const Vec3d a = tri.a - q, b = tri.b - q, c = tri.c - q;
    const double la = length(a), lb = length(b), lc = length(c);
    const double num = dot(a, cross(b, c));
    const double den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
    return 2.0 * std::atan2(num, den);
}

/// 1 / 4π: a solid angle as a winding number.
constexpr double kInverseFourPi = 0.079577471545947667884;

}  // namespace raycastd::engine
