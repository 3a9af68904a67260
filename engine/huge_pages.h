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
// The trade: with THP's defrag in "madvise" mode (the default) a fault in an advised range may
// compact memory first when no free 2 MiB block is left (a fragmented machine): a slower first
// touch of that page, never a wrong answer. Huge pages only cover whole aligned 2 MiB blocks
// inside the range, so its ends stay on small pages and nothing beyond the buffer is held.
// Only buffers of kHugePageMinBytes and more are advised: glibc maps every allocation that large
// on its own (its mmap threshold grows to 32 MiB at most), so the advice covers the buffer alone
// and ends with it, never a part of the heap that later holds other memory.

#include <cstddef>
#include <cstdint>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace raycastd::engine {

/// Buffers smaller than this stay on small pages: glibc's largest mmap threshold (its
/// DEFAULT_MMAP_THRESHOLD_MAX on 64-bit systems), the size from which an allocation is always a
/// mapping of its own. 1M ray hits (72 MB) and 300,000 point answers (34 MB) are above it.
constexpr std::size_t kHugePageMinBytes = std::size_t{32} << 20;

/// Asks the kernel to back the whole pages of [p, p + bytes) with huge pages from their first
/// touch. Best effort: a refusal (another kernel, THP off) leaves them as they are.
inline void advise_huge_pages(void* p, std::size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (bytes < kHugePageMinBytes)
        return;
    // madvise takes whole pages of the base size (4 KiB on x86-64, 16 or 64 KiB on some arm64
    // kernels).
    static const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
    const auto begin = (reinterpret_cast<std::uintptr_t>(p) + page - 1) & ~(page - 1);
    const auto end = (reinterpret_cast<std::uintptr_t>(p) + bytes) & ~(page - 1);
    if (end > begin)
        (void)madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#else
    (void)p;
    (void)bytes;
#endif
}

/// Room for n elements in v, advised for huge pages before its first touch, when v must grow to
/// hold them; the old elements are then released, not copied (the callers assign or overwrite all
/// n next; should reserve throw, v is left empty). Nothing when v already has the room.
template <class T>
void reserve_fresh(std::vector<T>& v, std::size_t n) {
    if (v.capacity() >= n)
        return;
    std::vector<T>().swap(v);
    v.reserve(n);
    advise_huge_pages(v.data(), n * sizeof(T));
}

}  // namespace raycastd::engine
