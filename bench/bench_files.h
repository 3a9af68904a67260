#pragma once
// The files the C++ benches hand to the out-of-process peers (raycastd over HTTP, Open3D): the
// meshes as binary PLY (and as .npy arrays), the sphere workload as a scene document, the rays
// as .npy arrays of the binary API's 8-float records, and raw Embree's closest hits as the
// reference the peers are checked against. All go to a scratch folder in the build tree.

#include <cstdint>
#include <string>
#include <vector>

#include "bench/raw_embree.h"
#include "bench/workloads.h"

namespace raycastd::bench {

/// What shell command `cmd` printed on its standard output (a peer's one line of JSON); empty when
/// it could not be started. Its standard error goes where this process's does.
std::string command_output(const std::string& cmd);

/// Binary little-endian PLY: float x y z per vertex, uchar-counted int index lists per face.
/// Returns false when the file cannot be written.
bool write_ply(const std::string& path, const Workload& w);

/// A raycastd scene document (docs/api.md) with one sphere object per sphere of the workload.
bool write_sphere_scene(const std::string& path, const Workload& w);

/// A NumPy .npy file (format 1.0, C order) of float32 values with the given shape.
bool write_npy(const std::string& path, const float* data, std::vector<std::size_t> shape);
/// The same for uint32 values.
bool write_npy(const std::string& path, const std::uint32_t* data, std::vector<std::size_t> shape);

/// The rays as an (n, 8) float32 array: ox oy oz dx dy dz tmin tmax, the binary API record.
bool write_rays(const std::string& path, const std::vector<RayRecord>& rays);

/// `<stem>_t.npy`, `<stem>_object.npy` and `<stem>_primitive.npy` from raw Embree's hits.
bool write_hits(const std::string& stem, const RawHits& hits);

/// The mesh as `<stem>_vertices.npy` (n, 3) float32 and `<stem>_triangles.npy` (m, 3) uint32,
/// for peers that take arrays rather than files (Open3D).
bool write_mesh_arrays(const std::string& stem, const Workload& w);

}  // namespace raycastd::bench
