#pragma once
// The frame a float tracer computes in. Embree sees every coordinate relative to the centre of
// the scene's bounds (engine/accel/embree_accel.h), so the float rounding of a point p, of its
// own copy of a surface and of the t it reports are all of the order of float's unit roundoff
// times (|p − centre| + the scene's scale), not times |p|: a scene 1e6 units from the origin
// loses nothing. Whoever adds such an error to a bound of its own (spawned-ray origins,
// shade/spawn.h) takes the frame from the path that answers; a path that decides in double has
// none (scale 0).

#include "engine/math/vec3.h"

namespace raycastd::engine {

/// Where a float tracer's coordinates are centred and how large they get.
struct FloatFrame {
    Vec3d center;        ///< the origin of the float coordinates (the centre of the scene bounds)
    double scale = 0.0;  ///< the magnitude of the scene's float coordinates; 0: a double tracer
};

}  // namespace raycastd::engine
