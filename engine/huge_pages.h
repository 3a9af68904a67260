#pragma once
// Large answer buffers on transparent huge pages.
//
// Why: a batch's answers are written into a fresh vector (a request's), and filling it is first
// touch: the kernel zeroes and maps each 4 KiB page on its first write, serially, one fault each.
// For 1M point answers (112 MB) that took 64–76 ms on this machine, 10–15% of a 1M-point closest
// query on A's shell; backed by 2 MiB pages (one fault per 512 small ones) it took 37–46 ms
// (docs/points.md). Linux backs memory with huge pages on its first touch where the kernel's
// THP mode is "always", or "madvise" (Debian 12's default, and this machine's) and the range
// was advised, which is what this header does; the same as numpy does for its arrays of 4 MiB
// and more. Elsewhere, or with THP "never", nothing changes.
//
// The trade: a huge page is 2 MiB of resident memory for a buffer that may end within it (at most
// one such page at each end of a buffer of 8 MiB or more: under 50%, and far less for the large
// ones), and with THP's defrag in "madvise" mode a fault may compact memory first when no free
// 2 MiB block is left (a fragmented machine): a slower first touch of that page, never a wrong
// answer. Only buffers of kHugePageMinBytes and more are advised.

#include <cstddef>
#include <cstdint>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace raycastd::engine {

/// Buffers smaller than this stay on small pages: 4 huge pages' worth, where the fault savings
/// begin to matter and the rounding at the ends is small.
constexpr std::size_t kHugePageMinBytes = std::size_t{8} << 20;

/// Asks the kernel to back the whole pages of [p, p + bytes) with huge pages from their first
/// touch. Best effort: a refusal (another kernel, THP off) leaves them as they are.
inline void advise_huge_pages(void* p, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (bytes < kHugePageMinBytes)
        return;
    constexpr std::uintptr_t kPage = 4096;  // madvise takes whole pages of the base size
    const auto begin = (reinterpret_cast<std::uintptr_t>(p) + kPage - 1) & ~(kPage - 1);
    const auto end = (reinterpret_cast<std::uintptr_t>(p) + bytes) & ~(kPage - 1);
    if (end > begin)
        (void)madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
    (void)p;
    (void)bytes;
#endif
}

/// Room for n elements in v, advised for huge pages before its first touch, when v must grow to
/// hold them; the old elements are then released, not copied (the callers assign or overwrite all
/// n next). Nothing when v already has the room.
template <class T>
void reserve_fresh(std::vector<T>& v, std::size_t n) {
    if (v.capacity() >= n)
        return;
    std::vector<T>().swap(v);
    v.reserve(n);
    advise_huge_pages(v.data(), n * sizeof(T));
}

}  // namespace raycastd::engine
