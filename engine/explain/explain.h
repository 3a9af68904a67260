#pragma once
// The worked solution a student would write for "which object does this ray hit first?",
// following the CS3241 tutorial's method (docs/numerics.md, "The tutorial's method"):
//   * sphere: substitute l(t) = p + t·v into (x−a)²+(y−b)²+(z−c)² = r², collect the quadratic
//     A·t² + B·t + C = 0, its discriminant B² − 4AC and its roots;
//   * triangle: the plane ⟨n,x⟩ = ⟨n,a⟩ with n = ac × ab, t from ⟨n,l(t)⟩ = ⟨n,a⟩, the point d,
//     and the inside test "da×db, db×dc, dc×da point the same way".
// The algebra is the tutorial's; the numbers come from the engine's stable kernels where the
// naive formula would lose digits (the discriminant is formed as in engine/geometry/sphere.h).

#include <optional>
#include <string>
#include <vector>

#include "engine/cancel.h"
#include "engine/math/ray.h"
#include "engine/scene/scene.h"
#include "engine/status.h"

namespace raycastd::engine {

struct SphereWork {
    double a = 0, b = 0, c = 0;  ///< A·t² + B·t + C = 0
    double discriminant = 0;     ///< B² − 4AC
    std::vector<double> roots;   ///< ascending; empty when there are no real roots
    /// False when A, B, C or the discriminant leave double's range (coordinates past ~1e154):
    /// they are not shown, and the roots come from the engine's rescaled kernel alone.
    bool representable = true;
};

struct TriangleWork {
    Vec3d normal;        ///< n = ac × ab (not normalised, as in the tutorial)
    double plane_d = 0;  ///< ⟨n,a⟩
    double n_dot_v = 0;  ///< ⟨n,v⟩; zero means the ray is parallel to the plane
    std::optional<double> t;
    std::optional<Vec3d> point;  ///< d = l(t)
    Vec3d cross[3];              ///< da×db, db×dc, dc×da
    bool same_direction = false;
    /// False when n, ⟨n,a⟩ or ⟨n,v⟩ leave double's range (coordinates past ~1e102, or edges
    /// below ~1e-150): the plane method is not worked, the watertight test decides (t and
    /// point are its answer, cross products are not computed).
    bool representable = true;
};

struct ObjectWork {
    std::uint32_t index = 0;
    std::string name;
    ObjectKind kind = ObjectKind::sphere;
    std::vector<std::string> steps;  ///< the lines a student would write, in order
    std::optional<SphereWork> sphere;
    std::optional<TriangleWork> triangle;
    std::size_t triangles = 0;  ///< mesh objects: how many triangles were tested
    bool hit = false;
    std::optional<double> t;  ///< the first t in [tmin, tmax] when hit
    std::string reason;       ///< why it misses, when it does
};

struct Explanation {
    std::vector<ObjectWork> objects;
    std::optional<Hit> first_hit;  ///< the engine's closest hit (exact path), if any
    Vec3d first_point;             ///< l(first_hit.t): hit_point (engine/query/intersect.h)
};

/// Works the solution for every object of the scene. The ray must be valid. Code::cancelled
/// once `cancel` has fired (asked per object, and per 65,536 triangles of a mesh).
Result<Explanation> explain(const Scene& scene, const Ray& ray, const CancelToken& cancel = {});

}  // namespace raycastd::engine
