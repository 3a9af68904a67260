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
      released_(std::exchange(other.released_, false)) {}

BuildBuffer& BuildBuffer::operator=(BuildBuffer&& other) noexcept {
    if (this != &other) {
        if (data_)
            munmap(data_, size_);
        data_ = std::exchange(other.data_, nullptr);
        size_ = std::exchange(other.size_, 0);
        released_ = std::exchange(other.released_, false);
    }
    return *this;
}

BuildBuffer::~BuildBuffer() {
    if (data_)
        munmap(data_, size_);
}

void BuildBuffer::release() {
    if (!data_ || released_)
        return;
    // MADV_DONTNEED drops the pages of a private anonymous mapping at once (a later touch would
    // find zeroes); PROT_NONE turns any touch into a fault instead.
    madvise(data_, size_, MADV_DONTNEED);
    mprotect(data_, size_, PROT_NONE);
    released_ = true;
}

}  // namespace raycastd::engine::embree
