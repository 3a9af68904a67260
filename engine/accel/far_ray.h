#pragma once
// A ray whose origin is far from a scene, moved along its own line to just before the scene and
// answered there, its answers then mapped back to the client's ray. From ~1e8 scene sizes away
// the double kernels, deciding on the far ray itself, err by ~u·distance (a − o rounds by
// u·|o|): a line through a point a third of the way inside a triangle, from 1e18 away, missed
// it. The move is formed in double-double, so that the moved ray lies within a few u of the
// scene's size of the client's line (MovedRay::line_err).
//
// EmbreeAccel moves its far rays relative to the scene centre (move_near_scene, float_ray.h);
// the brute-force paths (linear_accel.h) move them in world coordinates (move_near_ball_world),
// where the moved origin then rounds like an origin placed near the scene by the client.

#include <cmath>
#include <cstdint>
#include <vector>

#include "engine/geometry/sphere.h"
#include "engine/math/double_double.h"
#include "engine/math/ray.h"
#include "engine/scene/scene.h"

namespace raycastd::engine {

/// A ray moved along its own line to just before a scene (move_near_ball), and how to map its
/// answers back.
struct MovedRay {
    /// The same line, its origin two radii before the point nearest the centre (relative to
    /// the centre, or in world coordinates for move_near_ball_world), its direction the
    /// client's times 2^-exp (unit-sized): its parameter t' is τ − shift, τ = t·2^exp.
    Ray ray;
    int exp = 0;
    dd::DD shift;     ///< τ = shift + t' (double-double)
    double line_err;  ///< bound on the distance between the moved origin and the ray's line
    /// τ of the moved ray's t' (one rounding); the client's t is τ·2^-exp.
    double tau_of(double t_moved) const;
    /// The moved ray's t' of the client's t: τ − shift, rounded once (±inf stay; a τ that
    /// leaves double's range is ±inf or 0).
    double moved_t(double t) const;
};

/// What move_near_ball made of a ray.
enum class MoveResult {
    moved,         ///< `out` holds the moved ray
    misses,        ///< the line passes outside the ball: no hit
    not_possible,  ///< keep the ray as it is
};

/// The same line as `ray`, relative to `centre`, with its origin moved along it to two radii
/// before the point nearest the centre, formed in double-double (the direction scaled to unit
/// size by a power of two first). `misses` where the line passes outside the ball (centre,
/// radius); `not_possible` for a zero or non-finite direction, a radius that is not positive
/// and finite, or where the nearest point does not converge or lands beyond 4 radii. There is
/// no limit on the distance itself: past ~1e30 radii double-double no longer holds the shift
/// to a radius, and a ray that is moved all the same carries a line_err of that size into
/// its t_err (honest, and useless: 3.6e119 for a ball of radius 1.7 seen from 1e150, a
/// helper's probe).
MoveResult move_near_ball(const Vec3d& centre, double radius, const Ray& ray, MovedRay& out);

/// move_near_ball with the moved origin in world coordinates: centre + the relative origin,
/// rounded once per coordinate (u·|origin| more in line_err, √3 < 1.8 for the length).
MoveResult move_near_ball_world(const Vec3d& centre, double radius, const Ray& ray, MovedRay& out);

/// Whether every coordinate of v lies within ±reach; false for a NaN anywhere (a test of each
/// coordinate: std::max, as in max_abs, can drop a NaN). The far tests here and in
/// embree/float_ray.h.
inline bool within_reach(const Vec3d& v, double reach) {
    return std::abs(v.x) <= reach && std::abs(v.y) <= reach && std::abs(v.z) <= reach;
}

/// A ball around a scene, for the brute-force paths' far rays.
struct SceneBall {
    Vec3d centre;
    double radius = 0.0;
    bool usable = false;  ///< a scene with finite, non-empty bounds
    /// Whether `ray`'s origin lies farther than kFarRadii times the larger of the radius and
    /// the centre's largest coordinate from the centre on some axis (or is not a number there):
    /// the brute-force paths move such a ray.
    bool far(const Ray& ray) const {
        return usable && !within_reach(ray.origin - centre, far_reach);
    }
    /// far()'s reach: kFarRadii times the larger of the radius and the centre's largest
    /// coordinate. Made once by scene_ball: a renderer's scan asks far() of every ray it traces.
    double far_reach = 0.0;
};
/// 2^27 (~1.3e8): from there on the double kernels' u·distance is a few 1e-9 of the scene and
/// grows with the distance. EmbreeAccel marks far at about the same distance in scene sizes
/// (float_ray.h). Measured also against the centre's largest coordinate: moved in world
/// coordinates, the origin rounds by u·|centre|, which for a scene far from the world origin
/// can exceed what the triangle kernels lose on the far ray itself (the differential fuzz: a
/// scene 1e-4 across at 1.3e7 had t 4.28 ulps from the reference when moved from 1e11 radii
/// away). Such a scene's far rays are moved only from 2^27 times its distance from the world
/// origin on: a frame of the scene's own, as EmbreeAccel has, would move them sooner (not
/// done). Spheres are never answered on the moved ray (linear_accel.cpp says why).
inline constexpr double kFarRadii = 0x1p27;

/// The ball around the scene's bounds: their centre, and half their diagonal padded by 2⁻²⁰ of
/// itself and by u of the centre's coordinates for the rounding of both (so that every
/// primitive lies inside).
SceneBall scene_ball(const Scene& scene);

/// A hit of the moved ray `m` as the client's ray's: t mapped back, and t_err grown by what the
/// move can shift the crossing (the hit's object in `scene`).
void moved_back(const Scene& scene, const MovedRay& m, Hit& h);

/// The place along the moved ray `m` of a sphere's root that was decided on the client's ray
/// (`client`, root i of the client's roots in range), for ordering it among the moved ray's
/// other crossings: the moved ray's own root where its kernel finds as many (`on_moved`, `n`
/// of them), else its closest approach to the centre (a line within the move's error of
/// tangency: within the half-chord there, ~√(2r·line_err), of either root). t and t_err in the
/// moved ray's units; the rest is `client`'s.
Hit sphere_on_moved(const Sphere& s, const MovedRay& m, const Ray& moved_ray, const Hit& client,
                    int i, int n, const Hit* on_moved, int n_moved);

/// Of crossings sorted by `closer` (crossing `order[j]` is j-th, `hit(k)` is crossing k), those
/// an edge-duplicate merge keeps, in order: an on-edge crossing of an object, on one side,
/// within both t_errs of one kept before it is the same crossing found by the neighbouring
/// triangle at a shared edge or vertex. The merge of sort_and_merge_edge_duplicates (on the
/// client's t) and of sort_and_merge_on_moved (on the moved ray's).
template <class HitAt>
std::vector<std::size_t> kept_after_edge_merge(const std::vector<std::size_t>& order, HitAt hit) {
    std::vector<std::size_t> kept;
    kept.reserve(order.size());
    for (const std::size_t k : order) {
        const Hit& h = hit(k);
        bool duplicate = false;
        if (h.on_edge) {
            // Sorted by t: only the tail of `kept` can be within the error band.
            for (auto it = kept.rbegin(); it != kept.rend(); ++it) {
                const Hit& o = hit(*it);
                if (h.t - o.t > h.t_err + o.t_err)
                    break;
                if (o.object == h.object && o.on_edge && o.front_face == h.front_face) {
                    duplicate = true;
                    break;
                }
            }
        }
        if (!duplicate)
            kept.push_back(k);
    }
    return kept;
}

/// `all` for a far ray answered on its moved copy: `moved[k]` is crossing k in the moved ray's
/// frame (t, t_err), `out[k]` the same crossing as the client's ray's. Sorts `out` by `closer`
/// on the moved crossings, and drops edge duplicates there, as sort_and_merge_edge_duplicates
/// does on the client's t: from far enough every client t rounds to one double, and the list
/// had come in object order (its first entry not `closest`'s answer: a helper's review).
void sort_and_merge_on_moved(const std::vector<Hit>& moved, std::vector<Hit>& out);

}  // namespace raycastd::engine
