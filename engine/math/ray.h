#pragma once
// Ray and Hit: the values that flow through every query.

#include <cstdint>
#include <limits>

#include "engine/math/vec3.h"

namespace raycastd::engine {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr std::uint32_t kInvalidId = 0xFFFFFFFFu;

/// l(t) = origin + t·direction for tmin ≤ t ≤ tmax (both inclusive). The direction need not
/// be unit length: t is measured in units of the direction as given.
struct Ray {
    Vec3d origin;
    Vec3d direction;
    double tmin = 0.0;
    double tmax = kInfinity;

    Vec3d at(double t) const { return origin + direction * t; }
};

/// A surface hit. `normal` is the unit geometric normal as stored (outward for spheres,
/// normalize((b−a)×(c−a)) for triangles), never flipped towards the ray; `front_face` says
/// whether the ray arrived against it. `t_err` bounds |t − t_exact| for the path that answered.
struct Hit {
    double t = kInfinity;
    double t_err = 0.0;
    std::uint32_t object = kInvalidId;
    std::uint32_t primitive = kInvalidId;
    double u = 0.0;  ///< barycentric weight of b (hit = (1−u−v)·a + u·b + v·c); 0 for spheres
    double v = 0.0;  ///< barycentric weight of c
    Vec3d normal;
    bool front_face = true;
    /// The hit lies exactly on a triangle edge or vertex (an edge function was zero); used to
    /// report a crossing of a shared edge once.
    bool on_edge = false;

    bool valid() const { return object != kInvalidId; }
};

/// Closest-hit ordering of the API: smaller t first; exact ties go to the lower object index,
/// then to the lower primitive index.
inline bool closer(const Hit& a, const Hit& b) {
    if (a.t != b.t)
        return a.t < b.t;
    if (a.object != b.object)
        return a.object < b.object;
    return a.primitive < b.primitive;
}

}  // namespace raycastd::engine
