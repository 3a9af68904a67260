#pragma once
// A pinhole camera.

#include "engine/math/vec3.h"

namespace raycastd::engine {

struct Camera {
    Vec3d position{0.0, 0.0, 0.0};
    Vec3d look_at{0.0, 0.0, 1.0};
    Vec3d up{0.0, 1.0, 0.0};
    double fov_y_deg = 45.0;
};

}  // namespace raycastd::engine
