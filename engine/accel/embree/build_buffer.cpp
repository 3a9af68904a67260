#include "engine/accel/embree/build_buffer.h"

#include <utility>

#include <sys/mman.h>

namespace raycastd::engine::embree {

BuildBuffer::BuildBuffer(std::size_t bytes) {
    const std::size_t size = bytes + 16;
    // An anonymous mapping of its own, not the heap: its pages go back to the system when
    // released, whatever the allocator's thresholds (a heap block below them would stay).
    void* p = mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED)
        return;
    data_ = p;
    size_ = size;
}

BuildBuffer::BuildBuffer(BuildBuffer&& other) noexcept
    : data_(std::exchange(other.data_, nullptr)),
      size_(std::exchange(other.size_, 0)),
      used_(std::exchange(other.used_, 0)),
      released_(std::exchange(other.released_, false)) {}

BuildBuffer& BuildBuffer::operator=(BuildBuffer&& other) noexcept {
    if (this != &other) {
        if (data_)
            munmap(data_, size_);
        data_ = std::exchange(other.data_, nullptr);
        size_ = std::exchange(other.size_, 0);
        used_ = std::exchange(other.used_, 0);
        released_ = std::exchange(other.released_, false);
    }
    return *this;
}

BuildBuffer::~BuildBuffer() {
    if (data_)
        munmap(data_, size_);
}

void* BuildBuffer::carve(std::size_t bytes) {
    const std::size_t take = carved(bytes);
    if (!data_ || released_ || take > size_ - 16 - used_)
        return nullptr;
    void* p = static_cast<char*>(data_) + used_;
    used_ += take;
    return p;
}

void BuildBuffer::release() {
    if (!data_ || released_)
        return;
    // No access first: where the system refuses (mprotect can fail with ENOMEM when it would
    // split a mapping past the process's limit) the buffer stays as it was, resident, readable
    // and counted, rather than zeroed and readable. Then MADV_DONTNEED, which drops the pages of
    // a private anonymous mapping at once.
    if (mprotect(data_, size_, PROT_NONE) != 0)
        return;
    madvise(data_, size_, MADV_DONTNEED);
    released_ = true;
}

bool share_triangle_buffers(RTCGeometry g, BuildBuffer& buffer, std::size_t vertices,
                            std::size_t triangles, float*& v, unsigned*& idx) {
    v = static_cast<float*>(buffer.carve(vertices * 3 * sizeof(float)));
    idx = static_cast<unsigned*>(buffer.carve(triangles * 3 * sizeof(unsigned)));
    if (!v || !idx)
        return false;
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, v, 0,
                               3 * sizeof(float), vertices);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, idx, 0,
                               3 * sizeof(unsigned), triangles);
    return true;
}

bool can_release_built_buffers(RTCDevice device) {
#if RTC_VERSION_MAJOR == 3 && RTC_VERSION_MINOR == 13
    return device && rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_MAJOR) == 3 &&
           rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION_MINOR) == 13;
#else
    (void)device;
    return false;
#endif
}

}  // namespace raycastd::engine::embree
