#pragma once
// A pinhole camera.

#include <cmath>

#include "engine/math/vec3.h"

namespace raycastd::engine {

struct Camera {
    Vec3d position{0.0, 0.0, 0.0};
    Vec3d look_at{0.0, 0.0, 1.0};
    Vec3d up{0.0, 1.0, 0.0};
    double fov_y_deg = 45.0;
};

/// Whether a camera has a view at all: look_at differs from position and up is not parallel to
/// the view direction (the scene document's rules, docs/api.md), with a finite position.
inline bool has_view(const Camera& c) {
    return is_finite(c.position) && is_finite(c.look_at) && c.look_at != c.position &&
           length(cross(c.look_at - c.position, c.up)) > 0.0;
}

/// Moves look_at along the camera's view axis to where the axis passes closest to `target`
/// (t = ⟨target − position, f⟩ along the unit forward f), when that point is ahead by more than
/// a thousandth of `radius` and the camera keeps its view; otherwise leaves it. For a camera
/// that has a direction and no target (a glTF camera, §3.10.1), so that look_at, the pivot the
/// preview page orbits about, lies in the middle of the scene: one unit ahead, an orbit swings
/// the scene out of the picture. The rays keep their direction up to the rounding of
/// normalize(look_at − position), a few ulps.
inline void aim_at(Camera& c, const Vec3d& target, double radius) {
    const Vec3d forward = normalize(c.look_at - c.position);
    const double t = dot(target - c.position, forward);
    if (!(t > 1e-3 * radius) || !std::isfinite(t))
        return;
    Camera aimed = c;
    aimed.look_at = c.position + forward * t;
    if (has_view(aimed))
        c = aimed;
}

}  // namespace raycastd::engine
