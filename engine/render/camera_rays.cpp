#include "engine/render/camera_rays.h"

#include <cmath>

#include <immintrin.h>

#include "engine/geometry/target_clones.h"

namespace raycastd::engine {

namespace {

/// One component of forward + right·a + up·b on four lanes, summed left to right as Vec3d's
/// operators sum it.
[[gnu::target("avx"), gnu::always_inline]] inline __m256d along_avx(double fc, double rc, double uc,
                                                                    __m256d a, __m256d b) {
    return _mm256_add_pd(_mm256_add_pd(_mm256_set1_pd(fc), _mm256_mul_pd(_mm256_set1_pd(rc), a)),
                         _mm256_mul_pd(_mm256_set1_pd(uc), b));
}

/// CameraRays::ray on four image points in AVX's registers: the same operations in the same
/// order (the build has no FMA contraction: -ffp-contract=off), so the same bits
/// (`Render.CameraRaysFourAtATimeAreOneByOnes`). A lane whose direction's length is outside
/// normalize()'s plain range is normalised again by normalize() itself.
[[gnu::target("avx")]] void rays4_avx(const Vec3d& origin, const Vec3d& f, const Vec3d& r,
                                      const Vec3d& u, double width, double height, Ray* out,
                                      const double* x, const double* y) {
    const __m256d px = _mm256_loadu_pd(x), py = _mm256_loadu_pd(y);
    const __m256d two = _mm256_set1_pd(2.0), one = _mm256_set1_pd(1.0);
    // a = 2x/W − 1, b = 1 − 2y/H, as ((2·x)/W) − 1 and 1 − ((2·y)/H).
    const __m256d a =
        _mm256_sub_pd(_mm256_div_pd(_mm256_mul_pd(two, px), _mm256_set1_pd(width)), one);
    const __m256d b =
        _mm256_sub_pd(one, _mm256_div_pd(_mm256_mul_pd(two, py), _mm256_set1_pd(height)));
    const __m256d dx = along_avx(f.x, r.x, u.x, a, b), dy = along_avx(f.y, r.y, u.y, a, b),
                  dz = along_avx(f.z, r.z, u.z, a, b);
    // normalize(): length √((x² + y²) + z²), then each component divided by it.
    const __m256d len = _mm256_sqrt_pd(_mm256_add_pd(
        _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)), _mm256_mul_pd(dz, dz)));
    const int plain = _mm256_movemask_pd(
        _mm256_and_pd(_mm256_cmp_pd(len, _mm256_set1_pd(kNormalizePlainMin<double>), _CMP_GE_OQ),
                      _mm256_cmp_pd(len, _mm256_set1_pd(kNormalizePlainMax<double>), _CMP_LE_OQ)));
    alignas(32) double ux[4], uy[4], uz[4], vx[4], vy[4], vz[4];
    _mm256_store_pd(ux, _mm256_div_pd(dx, len));
    _mm256_store_pd(uy, _mm256_div_pd(dy, len));
    _mm256_store_pd(uz, _mm256_div_pd(dz, len));
    _mm256_store_pd(vx, dx);
    _mm256_store_pd(vy, dy);
    _mm256_store_pd(vz, dz);
    for (int j = 0; j < 4; ++j) {
        Ray& ray = out[j];
        ray.origin = origin;
        ray.direction =
            (plain >> j & 1) ? Vec3d{ux[j], uy[j], uz[j]} : normalize(Vec3d{vx[j], vy[j], vz[j]});
        ray.tmin = 0.0;
        ray.tmax = kInfinity;
    }
}

}  // namespace

Camera resolve_camera(const Scene& scene, const std::optional<Camera>& requested, int width,
                      int height) {
    if (requested)
        return *requested;
    if (scene.camera)
        return *scene.camera;
    return default_camera(scene.bounds(), static_cast<double>(width) / height,
                          scene.default_view());
}

CameraRays::CameraRays(const Camera& camera, int width, int height)
    : origin_(camera.position), width_(width), height_(height) {
    forward_ = normalize(camera.look_at - camera.position);
    right_ = normalize(cross(forward_, camera.up));
    up_ = cross(right_, forward_);
    const double tan_half = std::tan(0.5 * camera.fov_y_deg * M_PI / 180.0);
    up_ = up_ * tan_half;
    right_ = right_ * (tan_half * width_ / height_);
}

void CameraRays::rays4(Ray* out, const double* x, const double* y) const {
    if (cpu_has_avx())
        return rays4_avx(origin_, forward_, right_, up_, width_, height_, out, x, y);
    for (int j = 0; j < 4; ++j)
        ray(out[j], x[j], y[j]);
}

}  // namespace raycastd::engine
