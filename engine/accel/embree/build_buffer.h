#pragma once
// Memory for the vertex and index buffers of a scene's Embree geometries, one mapping for all of
// them, that gives its pages back once the BVH is built.
//
// Why: refined's triangles are widened each on its own (fat_triangles.h), three float vertices
// and an index triple a triangle, 48 B, which Embree reads while it builds and, in a scene
// Embree 3.13 builds as a BVH of Triangle4v leaves (RTC_SCENE_FLAG_ROBUST without
// RTC_SCENE_FLAG_COMPACT, the default build quality and "tri_accel"), never again: those leaves
// hold copies of the vertices (Embree 3.13.5, kernels/common/scene.cpp createTriangleAccel and
// kernels/geometry/trianglev.h), and our filters, point queries and answers read the scene's own
// double triangles. Kept, the buffers were a quarter of the resident memory of a scene that has
// answered refined queries (issue 17's target is 130 B a triangle for everything;
// docs/numerics.md). A compact scene (Triangle4i leaves, which index the buffers), rtcInterpolate
// or a second commit would read them: none is used on a scene whose buffers are released. A
// helper's review read the rest of 3.13.5 for readers after the build (refit, the two-level
// builder, verify, point queries, filters, the destruction of a shared buffer) and found none
// on our paths. The same holds for fast's non-robust BVH (Triangle4 leaves, kernels/geometry/
// triangle.h).
//
// After release() the range stays mapped, with no access: a read by Embree that this reasoning
// missed faults at once, in the tests that run every query on such scenes, instead of reading
// whatever a later allocation put there.

#include <cstddef>

#include <embree3/rtcore.h>

namespace raycastd::engine::embree {

class BuildBuffer {
  public:
    BuildBuffer() = default;
    /// `bytes` of zeroed, page-aligned memory, and 16 bytes beyond them (Embree may read a
    /// buffer's last element with a 16-byte load); data() is null when the system refuses.
    explicit BuildBuffer(std::size_t bytes);
    BuildBuffer(BuildBuffer&& other) noexcept;
    BuildBuffer& operator=(BuildBuffer&& other) noexcept;
    BuildBuffer(const BuildBuffer&) = delete;
    BuildBuffer& operator=(const BuildBuffer&) = delete;
    ~BuildBuffer();

    void* data() const { return data_; }
    /// The next `bytes` of the buffer, 16-byte aligned (several geometries' buffers in one
    /// mapping: a mapping each took a page each, 8 KiB a lone triangle, and a mapping count the
    /// system limits; a helper's review); null past its end or without memory.
    void* carve(std::size_t bytes);
    /// Bytes carve() takes for `bytes`.
    static std::size_t carved(std::size_t bytes) { return (bytes + 15) / 16 * 16; }
    /// Gives the pages back to the system and makes the range inaccessible (the file comment).
    void release();
    /// Bytes resident until release(), 0 after.
    std::size_t resident_bytes() const { return released_ ? 0 : size_; }

  private:
    void* data_ = nullptr;
    std::size_t size_ = 0;  ///< the whole mapping
    std::size_t used_ = 0;  ///< carved so far
    bool released_ = false;
};

/// Bytes share_triangle_buffers carves for `vertices` float3 vertices and `triangles` index
/// triples.
inline std::size_t triangle_buffer_bytes(std::size_t vertices, std::size_t triangles) {
    return BuildBuffer::carved(vertices * 3 * sizeof(float)) +
           BuildBuffer::carved(triangles * 3 * sizeof(unsigned));
}

/// A triangle geometry's vertex buffer (`vertices` float3) and index buffer (`triangles` uint3)
/// carved from `buffer` and shared with `g`, for the caller to fill through `v` and `idx`; false
/// where the buffer has no room (no memory), and nothing shared then.
bool share_triangle_buffers(RTCGeometry g, BuildBuffer& buffer, std::size_t vertices,
                            std::size_t triangles, float*& v, unsigned*& idx);

/// Whether the buffers of a triangle scene (ROBUST or not, never COMPACT) may be released after
/// its build: only with Embree 3.13 (the file comment: its Triangle4v and Triangle4 leaves), both
/// the headers compiled against and the library `device` runs.
bool can_release_built_buffers(RTCDevice device);

}  // namespace raycastd::engine::embree
