#pragma once
// Transform: a 4×4 affine transform in double precision, for placing model geometry in world
// space (glTF node transforms and the scene document's `transform` object).
//
// Convention: column vectors, p' = M·p, so M = A·B applies B first. This is the convention of
// glTF 2.0 §3.5.3 ("Transformations": a node's global transform is parent·child, and
// M = T·R·S) and of OpenGL. The bottom row is kept explicitly (always 0 0 0 1 for what we build)
// so that a glTF `matrix` round-trips unchanged.
//
// Normals transform by the inverse transpose of the upper 3×3 block (Turkowski, "Properties of
// Surface-Normal Transformations", Graphics Gems 1990, p. 539). We use the cofactor matrix,
// cof(A) = det(A)·A⁻ᵀ, scaled by sign(det A): it equals A⁻ᵀ up to a positive factor, needs no
// division, and stays defined (though possibly zero) when A is singular.

#include <array>

#include "engine/math/vec3.h"

namespace raycastd::engine {

class Transform {
  public:
    /// The identity.
    Transform() = default;

    /// From row-major elements m[row][col].
    explicit Transform(const std::array<std::array<double, 4>, 4>& rows) : m_(rows) {}

    /// Translation by t.
    static Transform translate(const Vec3d& t);
    /// Scale by s along x, y and z (negative factors mirror).
    static Transform scale(const Vec3d& s);
    /// Rotation by `deg` degrees counter-clockwise about the +x, +y or +z axis (right-handed).
    static Transform rotate_x_deg(double deg);
    static Transform rotate_y_deg(double deg);
    static Transform rotate_z_deg(double deg);
    /// Rotation by the unit quaternion (x, y, z, w), glTF's component order (glTF 2.0 §5.25
    /// `node.rotation`). The quaternion is normalized first; a zero or non-finite quaternion
    /// gives the identity rotation.
    static Transform rotate_quaternion(double x, double y, double z, double w);
    /// glTF TRS: M = T·R·S (glTF 2.0 §3.5.3), q = (x, y, z, w).
    static Transform from_trs(const Vec3d& translation, const std::array<double, 4>& q,
                              const Vec3d& scale);
    /// A glTF `matrix`: 16 numbers in column-major order (glTF 2.0 §5.25 `node.matrix`).
    static Transform from_column_major(const std::array<double, 16>& m);
    /// The scene document's `{"translate": t, "rotate_deg": [rx, ry, rz], "scale": s}`.
    /// Rotations are applied about the fixed world axes X first, then Y, then Z, i.e.
    /// R = Rz·Ry·Rx; scale is applied first and translation last: M = T·R·S.
    static Transform from_translate_rotate_scale(const Vec3d& translate, const Vec3d& rotate_deg,
                                                 const Vec3d& scale);

    /// Element at row r, column c (0..3).
    double operator()(int r, int c) const { return m_[idx(r)][idx(c)]; }
    const std::array<std::array<double, 4>, 4>& rows() const { return m_; }

    /// Composition: (A * B)(p) = A(B(p)).
    Transform operator*(const Transform& o) const;

    /// M·(p, 1): the affine image of a point.
    Vec3d apply_point(const Vec3d& p) const;
    /// M·(v, 0): the image of a direction (no translation); not normalized.
    Vec3d apply_vector(const Vec3d& v) const;
    /// normalize(M₃⁻ᵀ·n): the image of a surface normal, unit length. A singular M may map a
    /// normal to zero; zero stays zero (see normalize()).
    Vec3d apply_normal(const Vec3d& n) const;

    /// Determinant of the upper 3×3 block. Negative means the transform mirrors, which flips
    /// triangle winding (glTF 2.0 §3.7.2.1: a negative determinant of the global transform
    /// makes the front faces clockwise).
    double determinant3() const;
    /// True when every element is finite.
    bool is_finite() const;
    bool operator==(const Transform& o) const { return m_ == o.m_; }
    bool operator!=(const Transform& o) const { return !(*this == o); }

  private:
    static std::size_t idx(int i) { return static_cast<std::size_t>(i); }

    std::array<std::array<double, 4>, 4> m_{
        {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}};
};

}  // namespace raycastd::engine
