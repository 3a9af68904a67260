#include "engine/math/transform.h"

#include <cmath>

namespace raycastd::engine {

namespace {

constexpr double kPi = 3.14159265358979323846;

double radians(double deg) {
    return deg * (kPi / 180.0);
}

using Rows = std::array<std::array<double, 4>, 4>;

}  // namespace

Transform Transform::translate(const Vec3d& t) {
    return Transform(Rows{{{1, 0, 0, t.x}, {0, 1, 0, t.y}, {0, 0, 1, t.z}, {0, 0, 0, 1}}});
}

Transform Transform::scale(const Vec3d& s) {
    return Transform(Rows{{{s.x, 0, 0, 0}, {0, s.y, 0, 0}, {0, 0, s.z, 0}, {0, 0, 0, 1}}});
}

namespace {
// Whole multiples of 90° are snapped to exact 0/±1 so that "rotate_deg": [0, 90, 0] maps grid
// points onto grid points without a 6e-17 residue (sin(π/2·k) is not exact in floating point).
void sin_cos_deg(double deg, double& s, double& c) {
    double quarter = deg / 90.0;
    if (std::isfinite(quarter) && quarter == std::floor(quarter)) {
        static constexpr double kSin[4] = {0, 1, 0, -1};
        static constexpr double kCos[4] = {1, 0, -1, 0};
        double k = std::fmod(quarter, 4.0);
        if (k < 0)
            k += 4.0;
        auto i = static_cast<std::size_t>(k);
        s = kSin[i];
        c = kCos[i];
        return;
    }
    s = std::sin(radians(deg));
    c = std::cos(radians(deg));
}
}  // namespace

// The three right-handed axis rotations (Foley et al., Computer Graphics: Principles and
// Practice, 2nd ed., §5.7).
Transform Transform::rotate_x_deg(double deg) {
    double s, c;
    sin_cos_deg(deg, s, c);
    return Transform(Rows{{{1, 0, 0, 0}, {0, c, -s, 0}, {0, s, c, 0}, {0, 0, 0, 1}}});
}

Transform Transform::rotate_y_deg(double deg) {
    double s, c;
    sin_cos_deg(deg, s, c);
    return Transform(Rows{{{c, 0, s, 0}, {0, 1, 0, 0}, {-s, 0, c, 0}, {0, 0, 0, 1}}});
}

Transform Transform::rotate_z_deg(double deg) {
    double s, c;
    sin_cos_deg(deg, s, c);
    return Transform(Rows{{{c, -s, 0, 0}, {s, c, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}});
}

// Rotation matrix of the unit quaternion q = w + xi + yj + zk (Shoemake, "Animating Rotation
// with Quaternion Curves", SIGGRAPH 1985, eq. for Rot(q)).
Transform Transform::rotate_quaternion(double x, double y, double z, double w) {
    double n = std::sqrt(x * x + y * y + z * z + w * w);
    if (!(n > 0.0) || !std::isfinite(n))
        return Transform();
    x /= n;
    y /= n;
    z /= n;
    w /= n;
    return Transform(Rows{{{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), 0},
                           {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w), 0},
                           {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y), 0},
                           {0, 0, 0, 1}}});
}

Transform Transform::from_trs(const Vec3d& translation, const std::array<double, 4>& q,
                              const Vec3d& s) {
    return translate(translation) * rotate_quaternion(q[0], q[1], q[2], q[3]) * scale(s);
}

Transform Transform::from_column_major(const std::array<double, 16>& m) {
    Rows r{};
    for (std::size_t c = 0; c < 4; ++c) {
        for (std::size_t row = 0; row < 4; ++row)
            r[row][c] = m[c * 4 + row];
    }
    return Transform(r);
}

Transform Transform::from_translate_rotate_scale(const Vec3d& t, const Vec3d& rotate_deg,
                                                 const Vec3d& s) {
    return translate(t) * rotate_z_deg(rotate_deg.z) * rotate_y_deg(rotate_deg.y) *
           rotate_x_deg(rotate_deg.x) * scale(s);
}

Transform Transform::operator*(const Transform& o) const {
    Rows r{};
    for (std::size_t i = 0; i < 4; ++i) {
        for (std::size_t j = 0; j < 4; ++j) {
            double sum = 0.0;
            for (std::size_t k = 0; k < 4; ++k)
                sum += m_[i][k] * o.m_[k][j];
            r[i][j] = sum;
        }
    }
    return Transform(r);
}

Vec3d Transform::apply_point(const Vec3d& p) const {
    return {m_[0][0] * p.x + m_[0][1] * p.y + m_[0][2] * p.z + m_[0][3],
            m_[1][0] * p.x + m_[1][1] * p.y + m_[1][2] * p.z + m_[1][3],
            m_[2][0] * p.x + m_[2][1] * p.y + m_[2][2] * p.z + m_[2][3]};
}

Vec3d Transform::apply_vector(const Vec3d& v) const {
    return {m_[0][0] * v.x + m_[0][1] * v.y + m_[0][2] * v.z,
            m_[1][0] * v.x + m_[1][1] * v.y + m_[1][2] * v.z,
            m_[2][0] * v.x + m_[2][1] * v.y + m_[2][2] * v.z};
}

// n' ∝ A⁻ᵀ·n. With aᵢ the i-th column of A, A⁻¹ has the rows (a₁×a₂, a₂×a₀, a₀×a₁)/det(A)
// (the adjugate, Cramer's rule), so A⁻ᵀ·n = (n.x·(a₁×a₂) + n.y·(a₂×a₀) + n.z·(a₀×a₁))/det(A).
// Only the sign of det(A) matters once the result is normalized.
Vec3d Transform::apply_normal(const Vec3d& n) const {
    Vec3d a0{m_[0][0], m_[1][0], m_[2][0]};
    Vec3d a1{m_[0][1], m_[1][1], m_[2][1]};
    Vec3d a2{m_[0][2], m_[1][2], m_[2][2]};
    Vec3d c0 = cross(a1, a2), c1 = cross(a2, a0), c2 = cross(a0, a1);
    Vec3d r = c0 * n.x + c1 * n.y + c2 * n.z;
    if (determinant3() < 0.0)
        r = -r;
    return normalize(r);
}

double Transform::determinant3() const {
    return m_[0][0] * (m_[1][1] * m_[2][2] - m_[1][2] * m_[2][1]) -
           m_[0][1] * (m_[1][0] * m_[2][2] - m_[1][2] * m_[2][0]) +
           m_[0][2] * (m_[1][0] * m_[2][1] - m_[1][1] * m_[2][0]);
}

bool Transform::is_finite() const {
    for (const auto& row : m_) {
        for (double v : row) {
            if (!std::isfinite(v))
                return false;
        }
    }
    return true;
}

}  // namespace raycastd::engine
