#pragma once
// Scratch arrays of a build in anonymous mappings of their own.
//
// Why: glibc's malloc raises its mmap threshold to the size of any block it had mapped on its own
// once that block is freed (up to 32 MiB; mallopt(3), M_MMAP_THRESHOLD), and from then on keeps
// every smaller block in the heap, where freed memory stays resident until the heap's free top
// passes twice that threshold. A scene build frees megabytes of scratch (exact's BVH built as
// float nodes, reserved for as many nodes as primitives: 18 MB on A's 82k triangles), so after
// it the structures built next, and the scratch they free, stayed in the heap: 12 B a triangle
// of A's resident memory was freed heap (issue 17's target is 130 B; docs/numerics.md, the
// memory of a scene). An array in a mapping of its own gives its pages back when it is freed and
// leaves the allocator's thresholds as they were.
//
// For arrays of a build, sized by the scene and freed with it: each allocation is at least a
// page and a system call, so nothing small or frequent.

#include <cstddef>
#include <limits>
#include <new>
#include <vector>

#if defined(__unix__)
#include <sys/mman.h>
#endif

namespace raycastd::engine {

template <class T>
struct MappedAllocator {
    using value_type = T;

    MappedAllocator() = default;
    template <class U>
    MappedAllocator(const MappedAllocator<U>&) noexcept {}

    T* allocate(std::size_t n) {
        if (n > std::numeric_limits<std::size_t>::max() / sizeof(T))
            throw std::bad_array_new_length();
#if defined(__unix__)
        // Pages of an anonymous mapping are zeroed on first touch, and only those touched are
        // resident: a reservation larger than the use costs address space, not memory.
        void* p =
            mmap(nullptr, bytes(n), PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (p == MAP_FAILED)
            throw std::bad_alloc();
        return static_cast<T*>(p);
#else
        return static_cast<T*>(::operator new (bytes(n), std::align_val_t{alignof(T)}));
#endif
    }

    void deallocate(T* p, std::size_t n) noexcept {
#if defined(__unix__)
        munmap(p, bytes(n));
#else
        ::operator delete (p, std::align_val_t{alignof(T)});
        (void)n;
#endif
    }

  private:
    /// A zero-length mapping is refused: at least a byte (the system rounds up to a page).
    static std::size_t bytes(std::size_t n) {
        return n == 0 ? 1 : n * sizeof(T);
    }
};

/// Every MappedAllocator frees what any other allocated (they hold nothing), whatever their
/// element types: templates outside the class, so that MappedAllocator<int> compares with
/// MappedAllocator<long> (as friends taking the class, the converting constructor made the two
/// overloads ambiguous).
template <class T, class U>
bool operator==(const MappedAllocator<T>&, const MappedAllocator<U>&) {
    return true;
}
template <class T, class U>
bool operator!=(const MappedAllocator<T>&, const MappedAllocator<U>&) {
    return false;
}

/// A build's scratch array (the file comment).
template <class T>
using MappedVector = std::vector<T, MappedAllocator<T>>;

}  // namespace raycastd::engine
