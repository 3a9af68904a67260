#pragma once
// The benchmark workloads (A: an 81,920-triangle icosphere; B: 200 icospheres, 1,024,000
// triangles; C: 1,000 spheres; docs/benchmarks.md), generated with fixed seeds so that every
// peer (raw Embree, the engine in-process, raycastd over HTTP, Open3D) sees the same geometry and
// the same rays in the same run:
//   A  icosphere, subdivision level 6: 81,920 triangles;
//   B  200 icospheres of level 4 merged into one mesh: 1,024,000 triangles;
//   C  1000 analytic spheres.
// Rays: coherent camera rays (a pinhole camera framing the object) and incoherent random rays
// (origins uniform in the bounds scaled 1.5× about their centre, directions uniform on the sphere).

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/scene/scene.h"

namespace raycastd::bench {

/// One ray as the binary API sends it: `ox oy oz dx dy dz tmin tmax`, 32 bytes, no padding.
struct RayRecord {
    float ox, oy, oz;
    float dx, dy, dz;
    float tmin, tmax;
};
static_assert(sizeof(RayRecord) == 32, "RayRecord must match the binary API record");

/// The seeds of bench_intersect's workloads B and C and of its random rays, which bench_points
/// and bench_probe make again.
constexpr std::uint64_t kFieldSeed = 0x5eed0001;
constexpr std::uint64_t kSphereSeed = 0x5eed0002;
constexpr std::uint64_t kRaySeed = 0x5eed0003;

/// The sizes of the workloads and their ray sets in one of bench_intersect's presets (the full
/// run, --quick, --smoke), which bench_probe takes too.
struct WorkloadSizes {
    int ico_level;            ///< A: 20·4^level triangles
    int field_count;          ///< B: this many icospheres ...
    int field_level;          ///< ... of this level
    int spheres;              ///< C
    int image;                ///< coherent rays: image × image pixels
    std::size_t random_rays;  ///< incoherent rays
};
constexpr WorkloadSizes kFullSizes{6, 200, 4, 1000, 1024, std::size_t{1} << 20};
constexpr WorkloadSizes kQuickSizes{4, 50, 3, 200, 256, std::size_t{1} << 16};
constexpr WorkloadSizes kSmokeSizes{2, 8, 1, 20, 64, 4096};

/// The far end of every generated ray. Finite, because JSON cannot carry +inf; far beyond any
/// workload, so it clips nothing.
constexpr float kRayTmax = 1e30f;

/// Geometry in single precision: exactly what Embree receives. The engine gets the same values
/// widened to double, so both trace the same triangles.
struct Workload {
    std::string name;                                     ///< "A", "B" or "C"
    std::string description;                              ///< e.g. "icosphere, 81,920 triangles"
    std::vector<std::array<float, 3>> positions;          ///< triangle mesh vertices
    std::vector<std::array<std::uint32_t, 3>> triangles;  ///< counter-clockwise, outward
    std::vector<std::array<float, 4>> spheres;            ///< centre x, y, z and radius

    std::size_t primitive_count() const { return triangles.size() + spheres.size(); }
    /// Centre and radius of a sphere enclosing every primitive (about the box centre).
    std::array<float, 4> bounding_sphere() const;
    /// Axis-aligned bounds as {lo x, lo y, lo z, hi x, hi y, hi z}.
    std::array<float, 6> bounds() const;
};

/// A unit icosphere at the origin: the icosahedron subdivided `level` times with every new
/// vertex projected on the sphere; 20·4^level triangles, closed, shared vertices.
Workload make_icosphere(int level);

/// `count` icospheres of `level` with random centres and radii, merged into one mesh.
Workload make_icosphere_field(int count, int level, std::uint64_t seed);

/// `count` analytic spheres with random centres and radii.
Workload make_sphere_field(int count, std::uint64_t seed);

/// width × height pinhole-camera rays (45° vertical field of view) looking along +z at the
/// workload's bounding sphere, which just fits the image height. Rays are ordered in 4×4 pixel
/// tiles (tiles row by row, pixels row by row inside a tile), so 16 consecutive rays form a
/// coherent packet. width and height must be multiples of 4. Directions are unit length.
std::vector<RayRecord> camera_rays(const Workload& w, int width, int height);

/// n rays with origins uniform in the workload's bounds scaled 1.5× about their centre and
/// directions uniform on the unit sphere.
std::vector<RayRecord> random_rays(const Workload& w, std::size_t n, std::uint64_t seed);

/// The workload as an engine scene: one mesh object (A, B) or one object per sphere (C).
/// Workload 'A', 'B' or 'C' (any other letter: C) at sizes `s`, with the seeds above.
Workload make_workload(char name, const WorkloadSizes& s);
/// Its camera rays (`coherent`) or its random rays at sizes `s`.
std::vector<RayRecord> ray_set(const Workload& w, bool coherent, const WorkloadSizes& s);

engine::Scene to_engine_scene(const Workload& w);

/// The rays as engine rays (floats widened to double, exactly).
std::vector<engine::Ray> to_engine_rays(const std::vector<RayRecord>& rays);

}  // namespace raycastd::bench
