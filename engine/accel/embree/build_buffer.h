#pragma once
// Memory for an Embree geometry's vertex and index buffers that gives its pages back once the
// BVH is built.
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
// or a second commit would read them: none is used on a scene whose buffers are released.
//
// After release() the range stays mapped, with no access: a read by Embree that this reasoning
// missed faults at once, in the tests that run every query on such scenes, instead of reading
// whatever a later allocation put there.

#include <cstddef>

#include <embree3/rtcore_config.h>

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
    /// Gives the pages back to the system and makes the range inaccessible (the file comment).
    void release();
    /// Bytes resident until release(), 0 after.
    std::size_t resident_bytes() const { return released_ ? 0 : size_; }

  private:
    void* data_ = nullptr;
    std::size_t size_ = 0;  ///< the whole mapping
    bool released_ = false;
};

/// Whether the buffers of a ROBUST, non-compact triangle scene may be released after its build
/// with the Embree this was compiled against (the file comment: 3.13's Triangle4v leaves).
constexpr bool kReleaseBuiltBuffers =
#if RTC_VERSION_MAJOR == 3 && RTC_VERSION_MINOR == 13
    true;
#else
    false;
#endif

}  // namespace raycastd::engine::embree
