#pragma once
// Scene: the objects, materials, lights and camera of one scene, in world space and double
// precision. Built once, then shared read-only by every request (it has no mutable state).

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "engine/geometry/mesh.h"
#include "engine/geometry/sphere.h"
#include "engine/scene/camera.h"
#include "engine/scene/light.h"
#include "engine/scene/material.h"
#include "engine/status.h"

namespace raycastd::engine {

enum class ObjectKind { sphere, triangle, mesh };

/// One numbered object of the scene. A lone triangle is stored as a one-triangle mesh so that
/// every triangle goes through the same code.
struct Object {
    ObjectKind kind = ObjectKind::sphere;
    std::string name;
    std::uint32_t material = 0;                ///< index into Scene::materials
    Sphere sphere;                             ///< kind == sphere
    std::shared_ptr<const TriangleMesh> mesh;  ///< kind == triangle or mesh

    std::size_t primitive_count() const { return kind == ObjectKind::sphere ? 1 : mesh->size(); }
};

/// Which work a scene needs at all; work it does not need is skipped.
struct Features {
    bool shadows = false;     ///< at least one point or directional light
    bool reflection = false;  ///< some material reflects
    bool refraction = false;  ///< some material is transparent
    bool textures = false;    ///< some textured material is on a mesh with texture coordinates
};

/// Which side of its bounds a scene is seen from when neither the request nor the scene has a
/// camera of its own (default_camera, Scene::default_view).
enum class DefaultView {
    /// On −z, looking along +z: the tutorial's convention (its eye at the origin, the spheres at
    /// z = 8–10), for scenes of spheres and triangles.
    from_minus_z,
    /// On +z, looking along −z with +y up: a model's front. glTF 2.0 §3.4: "The front of a glTF
    /// asset faces +Z"; glTF viewers start there, and model viewers in general start from the
    /// OpenGL eye (on +z, looking down −z), whatever the file's format.
    from_plus_z,
};

struct Scene {
    std::vector<Object> objects;
    std::vector<Material> materials;  ///< materials[0] is the default grey Phong material
    std::vector<std::string> material_names;
    std::vector<Light> lights;
    std::optional<Camera> camera;
    std::vector<std::string> warnings;

    std::size_t triangle_count() const;
    std::size_t sphere_count() const;
    Bounds3 bounds() const;
    Features features() const;
    /// from_plus_z when some object is a mesh (a model file, whose front faces +z), else
    /// from_minus_z (spheres and triangles only: the tutorial's kind of scene).
    DefaultView default_view() const;
    /// Bytes of the decoded texture images the materials hold (each image counted once).
    std::size_t texture_bytes() const;
};

/// Checks the invariants every consumer relies on (finite coordinates, positive radii,
/// indices in range, material indices valid); the path names the offending object.
Status validate(const Scene& scene);

/// An object's bounds: its mesh's, or a sphere's centre ± radius rounded outward, so that the
/// box holds the whole sphere however small against its centre's coordinates.
Bounds3 object_bounds(const Object& o);

/// The default camera for an image of `aspect` = width / height: looks at the centre of the
/// bounds from the side `view` names (+y up), from the distance at which their bounding sphere
/// (centre, half the diagonal) just fills the narrower of the two fields of view
/// (engine/scene/scene.cpp); bounds flat in y (or x) are seen from 45° above (or beside), on the
/// same side. The camera at the origin looking along +z for empty bounds.
Camera default_camera(const Bounds3& bounds, double aspect, DefaultView view);
/// Bounds whose extent along y (or x) is at most this times their diagonal are flat there, and
/// default_camera looks at them from 45° above (or beside) rather than edge-on.
constexpr double kDefaultCameraFlat = 1e-6;

}  // namespace raycastd::engine
