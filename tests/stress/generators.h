#pragma once
// Adversarial scene and ray generators (issue 6): the inputs that break ray tracers. Every
// generator is deterministic in its seed. Suites that fit in 16 primitives come twice, as
// "<suite>" answered by the brute-force path and "<suite>/embree" padded with tiny far spheres
// so that QueryEngine builds Embree's BVH.

#include <cstdint>
#include <string>
#include <vector>

#include "tests/stress/harness.h"

namespace raycastd::stress {

/// How many rays each generator makes (per case); tests use the default, the report more.
struct GenOptions {
    int rays = 400;
    std::uint64_t seed = 1;
    int max_icosphere_level = 6;
};

/// Spheres of radius 1 at distances 1e3 … 1e9 from the rays' origins (distance/radius to 1e9);
/// rays aimed at random points of each sphere's disc, some just outside it.
std::vector<StressCase> far_spheres(const GenOptions& g);
/// Spheres of radius 1e-6 … 1e-3 at distances 1 … 1e3.
std::vector<StressCase> tiny_spheres(const GenOptions& g);
/// Rays whose distance from the centre is r·(1 ± δ), δ from 1e-12 to 1e-4, and exactly
/// tangent rays built from representable points.
std::vector<StressCase> tangent_rays(const GenOptions& g);
/// Closed icospheres (levels 0 … max) and a cube; rays aimed exactly at vertices and at points
/// of edges, entering the solid. Leaks are counted here.
std::vector<StressCase> mesh_edges(const GenOptions& g);
/// The same on the closed models of $RAYCASTD_SHARED_DIR/data/models; empty when absent.
std::vector<StressCase> closed_models(const GenOptions& g, const std::string& shared_dir);
/// Triangles with an angle below 1e-6 rad; rays at their interiors and edges.
std::vector<StressCase> slivers(const GenOptions& g);
/// Spheres, triangles and icospheres offset by 1e7, rays local to them and from the origin.
std::vector<StressCase> huge_coordinates(const GenOptions& g);
/// Rays at 1e-2 … 1e-9 rad to a triangle's plane, hitting inside.
std::vector<StressCase> nearly_parallel(const GenOptions& g);
/// Origins exactly on a surface (sphere poles, triangle vertices and axis-aligned faces), with
/// tmin = 0 (a near-tie at t = 0) and with tmin just above 0 (the next surface is judged).
std::vector<StressCase> origin_on_surface(const GenOptions& g);
/// A mixed scene with directions of length 1e-6 … 1e6.
std::vector<StressCase> direction_lengths(const GenOptions& g);
/// Pairs of objects whose first hits are k ulps apart (k = 0 … 64), duplicate triangles in two
/// objects (exact ties: the lower object wins), touching spheres.
std::vector<StressCase> near_ties(const GenOptions& g);
/// Icospheres of radius 1 (level 3) at distances 1e3 … 1e9: the far-sphere case as triangles,
/// which Open3D can take too.
std::vector<StressCase> far_mesh_spheres(const GenOptions& g);
/// Origins 1e10 … 1e22 away from an icosphere of radius 1 (level 3), where the double
/// kernels deciding on the far ray itself err by ~u·distance and from ~1e16 on the float ray
/// cannot be placed: answered on the BVH by the ray moved along its line to the scene
/// (embree/float_ray.h). Half the rays run along an axis (their line is exactly the one aimed
/// at, through the sphere), half obliquely at it (their double origin and direction place the
/// line anywhere within ~u·distance of the aim: hits and misses).
std::vector<StressCase> far_origins(const GenOptions& g);

/// Every suite above, in one list.
std::vector<StressCase> all_suites(const GenOptions& g, const std::string& shared_dir);

/// Three closed icospheres (level 2), 20 spheres and 20 single triangles, with meshes of no
/// triangles first, between the icospheres and last: exact's BVH names each primitive by its
/// index among the scene's and finds the object from it (engine/accel/embree/exact_bvh.h),
/// which a wrong object or primitive would show. Rays at the icospheres' edges and vertices,
/// and from around the scene. Not in all_suites (the accuracy report's suites).
std::vector<StressCase> many_objects(const GenOptions& g);

/// A scene with one default material and no objects.
engine::Scene empty_scene();
/// A sphere object.
engine::Object sphere(engine::Vec3d center, double radius, std::string name = "sphere");
/// A one-triangle object.
engine::Object triangle(engine::Vec3d a, engine::Vec3d b, engine::Vec3d c,
                        std::string name = "triangle");

}  // namespace raycastd::stress
