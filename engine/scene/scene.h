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
    /// Bytes of the decoded texture images the materials hold (each image counted once).
    std::size_t texture_bytes() const;
};

/// Checks the invariants every consumer relies on (finite coordinates, positive radii,
/// indices in range, material indices valid); the path names the offending object.
Status validate(const Scene& scene);

/// The default camera for an image of `aspect` = width / height: looks along +z at the centre
/// of the bounds, from the distance at which their bounding sphere (centre, half the diagonal)
/// just fills the narrower of the two fields of view (engine/scene/scene.cpp). The camera at the
/// origin looking along +z for empty bounds.
Camera default_camera(const Bounds3& bounds, double aspect);

}  // namespace raycastd::engine
