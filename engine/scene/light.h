#pragma once
// Lights of the Phong model: one ambient term and any number of point and directional lights.

#include "engine/math/vec3.h"

namespace raycastd::engine {

enum class LightType { ambient, point, directional };

struct Light {
    LightType type = LightType::point;
    Vec3d position;   ///< point lights
    Vec3d direction;  ///< directional lights: the direction the light travels
    Vec3d intensity{1.0, 1.0, 1.0};
};

}  // namespace raycastd::engine
