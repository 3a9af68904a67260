#pragma once
// Bounds3: an axis-aligned box, empty until something is added to it.

#include <limits>

#include "engine/math/vec3.h"

namespace raycastd::engine {

struct Bounds3 {
    Vec3d lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
             std::numeric_limits<double>::infinity()};
    Vec3d hi{-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
             -std::numeric_limits<double>::infinity()};

    bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
    void extend(const Vec3d& p) {
        lo = min(lo, p);
        hi = max(hi, p);
    }
    void extend(const Bounds3& b) {
        lo = min(lo, b.lo);
        hi = max(hi, b.hi);
    }
    Vec3d center() const { return (lo + hi) * 0.5; }
    Vec3d diagonal() const { return hi - lo; }
};

}  // namespace raycastd::engine
