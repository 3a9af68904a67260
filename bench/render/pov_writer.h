#pragma once
// Writes a POV-Ray 3.7 scene equivalent to an engine scene, so that POV-Ray can render the same
// picture in the render benchmark. The mapping (POV-Ray 3.7 reference, "finish" and "camera"):
//   * camera: the image plane spans `up` = 2·tan(fov/2) and `right` = −up·aspect at distance 1
//     along `direction`; the negative `right` makes POV-Ray's left-handed camera right-handed
//     like ours, so the pictures are not mirrored;
//   * material: pigment = kd, finish { diffuse 1  ambient ka/kd  phong mean(ks)  phong_size n
//     reflection kr }, and transmit t with interior { ior } for transparency (POV-Ray also scales
//     the surface's own light by 1 − t, which the classic Whitted sum does not);
//   * lights: point → light_source; directional → a parallel light; ambient → ambient_light;
//   * meshes → mesh2 (with vertex normals when the mesh has them), spheres and triangles as such;
//   * max_trace_level = max_depth, black background.

#include <string>

#include "engine/scene/camera.h"
#include "engine/scene/scene.h"

namespace raycastd::bench {

/// The .pov text of `scene` seen by `camera` at width × height, recursion up to `max_depth`.
std::string to_pov(const engine::Scene& scene, const engine::Camera& camera, int width, int height,
                   int max_depth);

}  // namespace raycastd::bench
