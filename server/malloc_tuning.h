#pragma once
// glibc's malloc set for a render server: freed memory kept for the next request rather than
// handed back to the kernel at once (malloc_tuning.cpp says why and what it measured).

namespace raycastd::server {

/// glibc's trim threshold (kTrimThreshold) and mmap threshold (kMmapThreshold) set once, at
/// start-up, before any thread: true where they were set, false where the C library is not
/// glibc or refused them (nothing changes then).
bool tune_malloc();

/// Free memory at the top of a heap that glibc keeps rather than trims (per arena).
inline constexpr int kTrimThreshold = 16 << 20;
/// Blocks from this size up are mapped on their own and unmapped when freed (a render's image).
inline constexpr int kMmapThreshold = 4 << 20;

}  // namespace raycastd::server
