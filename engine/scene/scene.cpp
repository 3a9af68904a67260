#include "engine/scene/scene.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "engine/math/double_double.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine {

std::size_t Scene::triangle_count() const {
    std::size_t n = 0;
    for (const auto& o : objects) {
        if (o.kind != ObjectKind::sphere)
            n += o.mesh->size();
    }
    return n;
}

std::size_t Scene::sphere_count() const {
    return static_cast<std::size_t>(
        std::count_if(objects.begin(), objects.end(),
                      [](const Object& o) { return o.kind == ObjectKind::sphere; }));
}

namespace {

/// c − r rounded down and c + r rounded up (TwoSum's residual says which way c ± r rounded,
/// Knuth; Ogita, Rump & Oishi 2005). Rounded to nearest, a radius below half an ulp of its
/// centre's coordinates vanished: a sphere 1.6e-9 across centred at 2^24 had the box of its
/// centre alone, and the exact BVH's traversal passed by rays through it (the differential
/// fuzzer, seed 6218; tests/stress/regressions/exact-miss-sphere-below-an-ulp-of-its-centre.txt).
double minus_down(double c, double r) {
    const dd::DD s = dd::two_sum(c, -r);
    return s.lo < 0.0 ? next_down(s.hi) : s.hi;
}
double plus_up(double c, double r) {
    const dd::DD s = dd::two_sum(c, r);
    return s.lo > 0.0 ? next_up(s.hi) : s.hi;
}

}  // namespace

Bounds3 object_bounds(const Object& o) {
    if (o.kind != ObjectKind::sphere)
        return o.mesh->bounds();
    const Vec3d& c = o.sphere.center;
    const double r = o.sphere.radius;
    Bounds3 b;
    b.extend({minus_down(c.x, r), minus_down(c.y, r), minus_down(c.z, r)});
    b.extend({plus_up(c.x, r), plus_up(c.y, r), plus_up(c.z, r)});
    return b;
}

Bounds3 Scene::bounds() const {
    Bounds3 b;
    for (const auto& o : objects)
        b.extend(object_bounds(o));
    return b;
}

Features Scene::features() const {
    Features f;
    for (const auto& l : lights) {
        if (l.type != LightType::ambient)
            f.shadows = true;
    }
    f.shadows = f.shadows && !objects.empty();
    for (const auto& m : materials) {
        if (m.reflectivity > 0.0)
            f.reflection = true;
        if (m.transparency > 0.0)
            f.refraction = true;
    }
    auto textured = [&](std::uint32_t m) { return m < materials.size() && materials[m].texture; };
    for (const auto& o : objects) {
        if (f.textures || !o.mesh || o.mesh->corner_uvs.size() != o.mesh->size())
            continue;
        f.textures = o.mesh->triangle_material.empty()
                         ? textured(o.material)
                         : std::any_of(o.mesh->triangle_material.begin(),
                                       o.mesh->triangle_material.end(), textured);
    }
    return f;
}

std::size_t Scene::texture_bytes() const {
    std::set<const TextureImage*> seen;
    std::size_t n = 0;
    for (const auto& m : materials) {
        if (m.texture && m.texture->image && seen.insert(m.texture->image.get()).second)
            n += m.texture->image->memory_bytes();
    }
    return n;
}

namespace {

std::string object_path(std::size_t i) {
    return "/objects/" + std::to_string(i);
}

}  // namespace

Status validate(const Scene& scene) {
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        const Object& o = scene.objects[i];
        if (o.material >= scene.materials.size()) {
            return Status::error(
                Code::invalid_scene,
                "object " + std::to_string(i) + " names a material that does not exist",
                object_path(i) + "/material");
        }
        if (o.kind == ObjectKind::sphere) {
            if (!is_finite(o.sphere.center)) {
                return Status::error(Code::invalid_scene, "sphere centre must be finite",
                                     object_path(i) + "/center");
            }
            if (!(o.sphere.radius > 0.0) || !std::isfinite(o.sphere.radius)) {
                return Status::error(Code::invalid_scene, "radius must be > 0 and finite",
                                     object_path(i) + "/radius");
            }
            continue;
        }
        if (!o.mesh) {
            return Status::error(Code::internal, "object without geometry", object_path(i));
        }
        const auto n = o.mesh->positions.size();
        for (const auto& p : o.mesh->positions) {
            if (!is_finite(p)) {
                return Status::error(Code::invalid_scene, "vertex coordinates must be finite",
                                     object_path(i));
            }
        }
        for (const auto& t : o.mesh->triangles) {
            if (t[0] >= n || t[1] >= n || t[2] >= n) {
                return Status::error(Code::model_load_failed, "triangle index out of range",
                                     object_path(i));
            }
        }
        for (std::uint32_t m : o.mesh->triangle_material) {
            if (m >= scene.materials.size()) {
                return Status::error(Code::model_load_failed, "triangle material out of range",
                                     object_path(i));
            }
        }
        if (!o.mesh->corner_uvs.empty() && o.mesh->corner_uvs.size() != o.mesh->size()) {
            return Status::error(Code::internal, "texture coordinates for some triangles only",
                                 object_path(i));
        }
    }
    // The scene's extent must be finite too: its bounds, and their size along each axis. A
    // sphere of radius 1e308 centred at 1e308 (its bounds' +x is inf) had every point query
    // answered "on the surface", since their error bound grows with the bounds; a triangle
    // from -1e308 to 1e308, whose edges overflow, was never hit (a helper's review). Such a
    // scene has surface points, or distances across it, that double cannot hold.
    // A mesh counts the vertices its triangles use: a file's unused vertices are no surface.
    const auto surface_bounds = [](const Object& o) {
        if (o.kind == ObjectKind::sphere)
            return object_bounds(o);
        Bounds3 b;
        for (const auto& t : o.mesh->triangles) {
            for (std::uint32_t k : t)
                b.extend(o.mesh->positions[k]);
        }
        return b;
    };
    Bounds3 all;
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        const Bounds3 b = surface_bounds(scene.objects[i]);
        if (b.empty())
            continue;
        const bool own = is_finite(b.lo) && is_finite(b.hi) && is_finite(b.diagonal());
        all.extend(b);
        if (!own || !is_finite(all.diagonal())) {
            return Status::error(
                Code::invalid_scene,
                std::string(own ? "with object " + std::to_string(i) + " the scene's"
                                : "object " + std::to_string(i) + "'s") +
                    " extent along x, y or z passes the largest double (about 1.8e308): "
                    "coordinates and the distances between them must stay within it",
                object_path(i));
        }
    }
    return {};
}

DefaultView Scene::default_view() const {
    const bool model = std::any_of(objects.begin(), objects.end(),
                                   [](const Object& o) { return o.kind == ObjectKind::mesh; });
    return model ? DefaultView::from_plus_z : DefaultView::from_minus_z;
}

Camera default_camera(const Bounds3& bounds, double aspect, DefaultView view) {
    Camera cam;
    if (bounds.empty())
        return cam;
    const Vec3d c = bounds.center();
    // Half the diagonal; 1e-9 only for bounds of no size (a point): as a floor it had framed a
    // mesh 1e-20 across from 1e-9 away, where it covered no pixel.
    const double half = 0.5 * scaled_length(bounds.diagonal());  // |d|² underflows at 1e-300
    const double radius = half > 0.0 ? half : 1e-9;
    // A sphere of radius r seen from distance d fills a cone of half-angle asin(r/d); it just
    // fills the image when that is the narrower half-angle of the pinhole's view. The vertical
    // one is fov_y/2; the horizontal one is atan(tan(fov_y/2)·W/H), since the image plane at
    // distance 1 spans ±tan(fov_y/2)·W/H across (engine/render/camera_rays.h).
    const double half_fov_y = 0.5 * cam.fov_y_deg * M_PI / 180.0;
    const double half_fov_x = aspect > 0.0 && std::isfinite(aspect)
                                  ? std::atan(std::tan(half_fov_y) * aspect)
                                  : half_fov_y;
    const double dist = radius / std::sin(std::min(half_fov_y, half_fov_x));
    // A scene flat across the image's up or right axis (a ground plane; TwoSidedPlane.gltf, whose
    // bounds have no height) is edge-on from ±z and shows nothing: it is seen from 45° above
    // (flat in y) or beside (flat in x) instead, on the side of the default view. Mirrored by
    // the preview page (clients/web/js/camera.js) and the grading kit (grader.py).
    const Vec3d e = bounds.diagonal();
    const double flat = kDefaultCameraFlat * scaled_length(e);
    Vec3d dir{0.0, 0.0, view == DefaultView::from_plus_z ? 1.0 : -1.0};
    if (e.y <= flat) {
        dir.y = 1.0;
    } else if (e.x <= flat) {
        dir.x = 1.0;
    }
    cam.look_at = c;
    cam.position = c + normalize(dir) * dist;
    return cam;
}

}  // namespace raycastd::engine
