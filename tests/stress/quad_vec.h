#pragma once
// Vectors of quads (tests/stress/reference.h's Quad): only what the references' formulas need.

#include <quadmath.h>

#include "engine/math/vec3.h"
#include "tests/stress/reference.h"

namespace raycastd::stress {

struct QVec {
    Quad x = 0, y = 0, z = 0;
};
inline QVec q(const engine::Vec3d& v) {
    return {v.x, v.y, v.z};
}
inline QVec operator-(const QVec& a, const QVec& b) {
    return {a.x - b.x, a.y - b.y, a.z - b.z};
}
inline QVec operator+(const QVec& a, const QVec& b) {
    return {a.x + b.x, a.y + b.y, a.z + b.z};
}
inline QVec operator*(const QVec& a, Quad s) {
    return {a.x * s, a.y * s, a.z * s};
}
inline Quad dot(const QVec& a, const QVec& b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline QVec cross(const QVec& a, const QVec& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline Quad norm(const QVec& a) {
    return sqrtq(dot(a, a));
}

}  // namespace raycastd::stress
