#pragma once
// Brute force over every primitive, in double precision: the exact path, and the fastest one
// for tiny scenes ("no BVH for three spheres"). Objects are visited in index order and
// primitives in file order, so the tie rules of the API (lower object, then lower primitive)
// fall out of the `closer` ordering.

#include <optional>
#include <vector>

#include "engine/accel/far_ray.h"
#include "engine/cancel.h"
#include "engine/scene/scene.h"

namespace raycastd::engine {

/// Closest hit of the ray over the whole scene, or nullopt. `cancel`, if given, is asked as
/// linear_closest_in_object asks it (nullopt once it has fired).
std::optional<Hit> linear_closest(const Scene& scene, const Ray& ray, bool want_normal,
                                  const CancelToken* cancel = nullptr);

/// The hit (if any) of one object; `object` and `primitive` are filled in. `cancel`, if given,
/// is asked once per kLinearCancelStride triangles (a single ray through a mesh of millions:
/// the worked solution), and nullopt is returned once it has fired.
std::optional<Hit> linear_closest_in_object(const Scene& scene, std::uint32_t object,
                                            const Ray& ray, bool want_normal,
                                            const CancelToken* cancel = nullptr);
/// Triangles tested between two checks of a CancelToken: about a millisecond of work.
constexpr std::size_t kLinearCancelStride = 1u << 16;

/// Whether anything is hit in [tmin, tmax]; stops at the first hit found.
bool linear_any(const Scene& scene, const Ray& ray);

/// Every hit along the ray, sorted by `closer`; a crossing of an edge or vertex shared by
/// triangles of one mesh is listed once (the lower-numbered triangle), a tangent sphere once.
void linear_all(const Scene& scene, const Ray& ray, bool want_normal, std::vector<Hit>& out);

/// linear_closest, linear_any and linear_all for rays from anywhere: where a ray's origin is
/// `ball.far` from the scene (~1e8 scene sizes and beyond, where the triangle kernel deciding
/// on the far ray itself errs by ~u·distance and misses triangles the line crosses), its
/// meshes are answered on the ray moved along its line to just before the scene (far_ray.h, in
/// world coordinates) and their hits mapped back (t, and t_err grown by what the move may shift
/// a crossing); its spheres on the ray as it is (their kernel loses nothing to the distance).
/// A line that passes outside the ball hits nothing; where the move is not possible the ray is
/// answered as it is. QueryEngine answers its brute-force scenes through these.
std::optional<Hit> linear_closest_from_afar(const Scene& scene, const SceneBall& ball,
                                            const Ray& ray, bool want_normal,
                                            const CancelToken* cancel = nullptr);
bool linear_any_from_afar(const Scene& scene, const SceneBall& ball, const Ray& ray);
void linear_all_from_afar(const Scene& scene, const SceneBall& ball, const Ray& ray,
                          bool want_normal, std::vector<Hit>& out);

/// Sorts hits by `closer` and drops the duplicates a shared edge or vertex produces: hits of the
/// same object, both on an edge, facing the same way (both entering or both leaving), whose t
/// agree within their error bounds. Keeping one entering and one leaving hit where a line only
/// touches a closed mesh at a silhouette edge or vertex keeps every count along a line through
/// a closed mesh even.
void sort_and_merge_edge_duplicates(std::vector<Hit>& hits);

}  // namespace raycastd::engine
