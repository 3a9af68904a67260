#include "server/malloc_tuning.h"

#include <cstdlib>  // any C library header defines __GLIBC__ where the library is glibc

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace raycastd::server {

// A fresh server's first render took twice as long as the next ones: 338–375 ms against
// 149–157 ms for tutorial_like at 640×480, spp 4 (X-Render-Breakdown's trace, three fresh
// servers, 2026-12-05). perf showed a fifth of that first render in madvise's TLB shootdowns and
// the page faults after them. glibc trims a heap whose free top passes its trim threshold,
// 128 KiB by default, handing the pages back with madvise(MADV_DONTNEED); every render thread
// has its arena, whose per-tile vectors of rays, hits and colours were freed and trimmed, then
// faulted in again at the next tile. glibc raises the threshold itself only once a block it had
// mapped on its own is freed (a render's image, at the end of the first render), which is why
// the second render did not pay. Set from the start (mallopt turns that adjustment off), with
// the mmap threshold at 4 MiB so that images and other large buffers are still mapped on their
// own and unmapped when freed, the first render took 148–157 ms, and resident memory after
// four renders was the same (20.5 MB).
bool tune_malloc() {
#if defined(__GLIBC__)
    return mallopt(M_MMAP_THRESHOLD, kMmapThreshold) == 1 &&
           mallopt(M_TRIM_THRESHOLD, kTrimThreshold) == 1;
#else
    return false;
#endif
}

}  // namespace raycastd::server
