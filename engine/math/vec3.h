#pragma once
// Vec3<T>: the one small vector type of the engine, for float (Embree's world) and double
// (the precise world). Conversions between the two are explicit so that no precision is lost or
// invented silently.

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace raycastd::engine {

template <class T>
struct Vec3 {
    T x{}, y{}, z{};

    constexpr Vec3() = default;
    constexpr Vec3(T x_, T y_, T z_) : x(x_), y(y_), z(z_) {}
    template <class U>
    constexpr explicit Vec3(const Vec3<U>& o)
        : x(static_cast<T>(o.x)), y(static_cast<T>(o.y)), z(static_cast<T>(o.z)) {}

    constexpr T operator[](std::size_t i) const { return i == 0 ? x : (i == 1 ? y : z); }
    constexpr T& operator[](std::size_t i) { return i == 0 ? x : (i == 1 ? y : z); }

    constexpr Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
    constexpr Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
    constexpr Vec3 operator-() const { return {-x, -y, -z}; }
    constexpr Vec3 operator*(T s) const { return {x * s, y * s, z * s}; }
    constexpr Vec3 operator/(T s) const { return {x / s, y / s, z / s}; }
    constexpr Vec3 operator*(const Vec3& o) const { return {x * o.x, y * o.y, z * o.z}; }
    Vec3& operator+=(const Vec3& o) { return *this = *this + o; }
    Vec3& operator-=(const Vec3& o) { return *this = *this - o; }
    Vec3& operator*=(T s) { return *this = *this * s; }
    constexpr bool operator==(const Vec3& o) const { return x == o.x && y == o.y && z == o.z; }
    constexpr bool operator!=(const Vec3& o) const { return !(*this == o); }
};

using Vec3f = Vec3<float>;
using Vec3d = Vec3<double>;

template <class T>
constexpr Vec3<T> operator*(T s, const Vec3<T>& v) {
    return v * s;
}
template <class T>
constexpr T dot(const Vec3<T>& a, const Vec3<T>& b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <class T>
constexpr Vec3<T> cross(const Vec3<T>& a, const Vec3<T>& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T>
T length(const Vec3<T>& v) {
    return std::sqrt(dot(v, v));
}
template <class T>
Vec3<T> abs(const Vec3<T>& v) {
    return {std::abs(v.x), std::abs(v.y), std::abs(v.z)};
}
template <class T>
T max_component(const Vec3<T>& v) {
    return std::fmax(v.x, std::fmax(v.y, v.z));
}
/// max(|v.x|, |v.y|, |v.z|) with plain comparisons, for finite v (a NaN component may or may
/// not win): std::fmax's NaN rule is a call into libm that GCC does not inline, and the error
/// bounds of the kernels take this for every candidate (fmax had been 4% of exact queries on a
/// closed mesh, and 1% of a small scene's render, perf).
template <class T>
T max_abs(const Vec3<T>& v) {
    const T x = std::abs(v.x), y = std::abs(v.y), z = std::abs(v.z);
    return std::max(x, std::max(y, z));
}
/// |v| where |v|² may overflow or underflow (components past ~1e154 or below ~1e-154): v is
/// divided by its largest component first, as std::hypot does. For lengths that must hold at
/// every scale (a scene's size), not for kernels: length() is the fast one.
template <class T>
T scaled_length(const Vec3<T>& v) {
    const T m = max_abs(v);
    if (!(m > T(0)) || !std::isfinite(m))
        return length(v);
    return m * length(v / m);
}
/// normalize()'s rare branch: v, whose length `len` overflowed, underflowed or is 0 or NaN,
/// divided by its largest component first. Out of line and cold, so that normalize() itself
/// stays small enough to inline: the branch in line had made it a call, 7% of a Duck render
/// (perf, bench_render --scenes duck --precisions fast).
template <class T>
[[gnu::cold, gnu::noinline]] Vec3<T> normalize_rescaled(const Vec3<T>& v, T len) {
    const T m = max_abs(v);
    if (!(m > T(0)) || !std::isfinite(m))
        return len > T(0) ? v / len : v;  // zero, NaN or infinite components: as they were
    const Vec3<T> w = v / m;              // exact in direction: its largest component is ±1
    return w / length(w);
}
/// The lengths normalize() divides by as they are; outside [min, max] (and for 0 and NaN) it
/// rescales first. Named for code that normalises in vector lanes and must take the same branch
/// (CameraRays::rays4).
template <class T>
inline constexpr T kNormalizePlainMin = T(sizeof(T) == sizeof(float) ? 0x1p-60 : 0x1p-500);
template <class T>
inline constexpr T kNormalizePlainMax = T(sizeof(T) == sizeof(float) ? 0x1p60 : 0x1p500);
/// v / |v|; the zero vector stays zero rather than becoming NaN. Where |v|² overflows or
/// underflows (double components past ~1e150 or below ~1e-150, float past ~1e18 or below
/// ~1e-18), v is divided by its largest component first, so that the answer is still a unit
/// vector: a triangle 1e78 across had the normal (0, 0, 0) from v / ∞, and one 1e-170 across
/// kept its unnormalised cross product (an adversarial review). Ordinary vectors take the first
/// branch and are divided as before, bit for bit.
template <class T>
inline Vec3<T> normalize(const Vec3<T>& v) {
    const T len = length(v);
    if (len >= kNormalizePlainMin<T> && len <= kNormalizePlainMax<T>)
        return v / len;
    return normalize_rescaled(v, len);
}
/// Index (0..2) of the component with the largest absolute value; ties go to the lower index.
template <class T>
std::size_t max_abs_dimension(const Vec3<T>& v) {
    T ax = std::abs(v.x), ay = std::abs(v.y), az = std::abs(v.z);
    if (ax >= ay && ax >= az)
        return 0;
    return ay >= az ? 1 : 2;
}
template <class T>
bool is_finite(const Vec3<T>& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}
template <class T>
Vec3<T> min(const Vec3<T>& a, const Vec3<T>& b) {
    return {std::fmin(a.x, b.x), std::fmin(a.y, b.y), std::fmin(a.z, b.z)};
}
template <class T>
Vec3<T> max(const Vec3<T>& a, const Vec3<T>& b) {
    return {std::fmax(a.x, b.x), std::fmax(a.y, b.y), std::fmax(a.z, b.z)};
}

}  // namespace raycastd::engine
