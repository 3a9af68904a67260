#pragma once
// Test helper: whether this translation unit is built under AddressSanitizer or ThreadSanitizer,
// for tests whose measurements a sanitizer changes (its allocator maps and keeps memory; its
// arithmetic is slower). GCC defines __SANITIZE_ADDRESS__ / __SANITIZE_THREAD__; clang (14, as
// Debian 12 has it) defines neither and answers __has_feature. Written once here for the tests
// above engine/testing/ in the layer order (engine/huge_pages_test.cpp, below it, keeps its own).

namespace raycastd::engine::testing {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kAddressSanitizer = true;
#else
inline constexpr bool kAddressSanitizer = false;
#endif
#else
inline constexpr bool kAddressSanitizer = false;
#endif

#if defined(__SANITIZE_THREAD__)
inline constexpr bool kThreadSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
inline constexpr bool kThreadSanitizer = true;
#else
inline constexpr bool kThreadSanitizer = false;
#endif
#else
inline constexpr bool kThreadSanitizer = false;
#endif

}  // namespace raycastd::engine::testing
