#include "engine/render/camera_rays.h"

#include <cmath>

namespace raycastd::engine {

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

}  // namespace raycastd::engine
