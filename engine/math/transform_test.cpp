#include "engine/math/transform.h"

#include <cmath>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

constexpr double kTol = 1e-12;

void expect_near(const Vec3d& a, const Vec3d& b, double tol = kTol) {
    EXPECT_NEAR(a.x, b.x, tol);
    EXPECT_NEAR(a.y, b.y, tol);
    EXPECT_NEAR(a.z, b.z, tol);
}

TEST(Transform, IdentityByDefault) {
    Transform t;
    EXPECT_EQ(t.apply_point({1, 2, 3}), Vec3d(1, 2, 3));
    EXPECT_EQ(t.apply_vector({1, 2, 3}), Vec3d(1, 2, 3));
    EXPECT_EQ(t.determinant3(), 1.0);
}

TEST(Transform, TranslateMovesPointsNotVectors) {
    Transform t = Transform::translate({1, -2, 3});
    EXPECT_EQ(t.apply_point({0, 0, 0}), Vec3d(1, -2, 3));
    EXPECT_EQ(t.apply_vector({0, 0, 1}), Vec3d(0, 0, 1));
}

// Right-handed rotations: +90° about z takes +x to +y; about x takes +y to +z; about y takes +z
// to +x. Multiples of 90° are exact.
TEST(Transform, AxisRotationsAreRightHandedAndExactAtQuarterTurns) {
    EXPECT_EQ(Transform::rotate_z_deg(90).apply_point({1, 0, 0}), Vec3d(0, 1, 0));
    EXPECT_EQ(Transform::rotate_x_deg(90).apply_point({0, 1, 0}), Vec3d(0, 0, 1));
    EXPECT_EQ(Transform::rotate_y_deg(90).apply_point({0, 0, 1}), Vec3d(1, 0, 0));
    EXPECT_EQ(Transform::rotate_y_deg(-270).apply_point({0, 0, 1}), Vec3d(1, 0, 0));
    expect_near(Transform::rotate_z_deg(45).apply_point({1, 0, 0}),
                {std::sqrt(0.5), std::sqrt(0.5), 0});
}

// The scene document order: scale first, then X, Y, Z rotations about the world axes, then the
// translation. Hand-derived: (1,0,0) scaled by 2 → (2,0,0); Rx(90) keeps it; Ry(90) takes +x to
// −z → (0,0,−2); Rz(90) keeps it; translate by (10,0,0) → (10,0,−2).
TEST(Transform, DocumentOrderIsTranslateRotateZYXScale) {
    Transform t = Transform::from_translate_rotate_scale({10, 0, 0}, {90, 90, 90}, {2, 2, 2});
    EXPECT_EQ(t.apply_point({1, 0, 0}), Vec3d(10, 0, -2));
    // (0,1,0) → (0,2,0) → Rx: (0,0,2) → Ry: (2,0,0) → Rz: (0,2,0) → (10,2,0).
    EXPECT_EQ(t.apply_point({0, 1, 0}), Vec3d(10, 2, 0));
}

// glTF quaternion (x, y, z, w) = (0, sin 45°, 0, cos 45°) is +90° about y.
TEST(Transform, QuaternionMatchesAxisRotation) {
    double h = std::sqrt(0.5);
    Transform q = Transform::rotate_quaternion(0, h, 0, h);
    expect_near(q.apply_point({0, 0, 1}), {1, 0, 0});
    // Non-unit quaternions are normalized; zero gives the identity.
    expect_near(Transform::rotate_quaternion(0, 3, 0, 3).apply_point({0, 0, 1}), {1, 0, 0});
    EXPECT_EQ(Transform::rotate_quaternion(0, 0, 0, 0), Transform());
}

// glTF 2.0 §3.5.3: M = T·R·S.
TEST(Transform, TrsAppliesScaleThenRotationThenTranslation) {
    double h = std::sqrt(0.5);
    Transform t = Transform::from_trs({1, 2, 3}, {0, 0, h, h}, {2, 1, 1});
    // (1,0,0) → S → (2,0,0) → Rz(90) → (0,2,0) → T → (1,4,3).
    expect_near(t.apply_point({1, 0, 0}), {1, 4, 3});
}

// A glTF `matrix` is column-major: elements 12..14 are the translation.
TEST(Transform, ColumnMajorMatrix) {
    Transform t = Transform::from_column_major({1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 5, 6, 7, 1});
    EXPECT_EQ(t(0, 3), 5.0);
    EXPECT_EQ(t(2, 3), 7.0);
    EXPECT_EQ(t.apply_point({1, 1, 1}), Vec3d(6, 7, 8));
    // Column 0 is the image of +x.
    Transform r = Transform::from_column_major({0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});
    EXPECT_EQ(r.apply_vector({1, 0, 0}), Vec3d(0, 1, 0));
}

TEST(Transform, CompositionAppliesRightOperandFirst) {
    Transform a = Transform::translate({1, 0, 0});
    Transform b = Transform::scale({2, 2, 2});
    EXPECT_EQ((a * b).apply_point({1, 0, 0}), Vec3d(3, 0, 0));
    EXPECT_EQ((b * a).apply_point({1, 0, 0}), Vec3d(4, 0, 0));
}

// Under a non-uniform scale a normal must stay perpendicular to the transformed surface: the
// plane x + y = 0 (normal (1,1,0)) scaled by (2,1,1) becomes x/2 + y = 0 with normal ∝ (1,2,0).
TEST(Transform, NormalsUseInverseTranspose) {
    Transform s = Transform::scale({2, 1, 1});
    expect_near(s.apply_normal({1, 1, 0}), normalize(Vec3d(1, 2, 0)));
    Vec3d tangent = s.apply_vector({1, -1, 0});
    EXPECT_NEAR(dot(tangent, s.apply_normal({1, 1, 0})), 0.0, kTol);
}

// A mirror flips the determinant; the normal of a mirrored surface is the mirrored normal.
TEST(Transform, MirrorHasNegativeDeterminantAndMirroredNormals) {
    Transform m = Transform::scale({-1, 1, 1});
    EXPECT_LT(m.determinant3(), 0.0);
    expect_near(m.apply_normal({1, 0, 0}), {-1, 0, 0});
    expect_near(m.apply_normal({0, 1, 0}), {0, 1, 0});
}

TEST(Transform, SingularTransformGivesZeroNotNaN) {
    Transform flat = Transform::scale({1, 1, 0});
    Vec3d n = flat.apply_normal({1, 0, 0});
    EXPECT_TRUE(is_finite(n));
    EXPECT_EQ(flat.determinant3(), 0.0);
}

TEST(Transform, FiniteCheck) {
    EXPECT_TRUE(Transform::translate({1, 2, 3}).is_finite());
    EXPECT_FALSE(Transform::translate({1, NAN, 3}).is_finite());
}

}  // namespace
}  // namespace raycastd::engine
