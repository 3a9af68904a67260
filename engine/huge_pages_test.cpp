// reserve_fresh: room without copying, and (where the kernel offers transparent huge pages) the
// room backed by them once touched. MappedAllocator (mapped_allocator.h): a build's scratch that
// gives its pages back when freed, whatever malloc's thresholds.

#include "engine/huge_pages.h"

#include <cstdint>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "engine/mapped_allocator.h"
#include "engine/process_memory.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace raycastd::engine {
namespace {

TEST(HugePages, ReserveFreshGrowsWithoutKeepingAndKeepsWhatHasRoom) {
    std::vector<int> v = {1, 2, 3};
    reserve_fresh(v, 1000);
    EXPECT_GE(v.capacity(), 1000u);
    EXPECT_TRUE(v.empty());  // released, not copied: the callers assign or overwrite all
    v.assign(10, 7);
    const int* before = v.data();
    reserve_fresh(v, 500);  // room enough: the same storage and contents
    EXPECT_EQ(v.data(), before);
    EXPECT_EQ(v.size(), 10u);
    EXPECT_EQ(v[9], 7);
}

/// The kernel's THP mode ("always", "madvise" or "never"), empty where it has none.
std::string thp_mode() {
    std::ifstream f("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string line;
    std::getline(f, line);
    const auto b = line.find('['), e = line.find(']');
    return b == std::string::npos || e == std::string::npos ? "" : line.substr(b + 1, e - b - 1);
}

/// kB of huge pages in the mapping that holds address a (/proc/self/smaps), or −1 if none holds
/// it.
long anon_huge_kb(std::uintptr_t a) {
    std::ifstream f("/proc/self/smaps");
    std::string line;
    bool in = false;
    while (std::getline(f, line)) {
        unsigned long lo = 0, hi = 0;
        if (std::sscanf(line.c_str(), "%lx-%lx ", &lo, &hi) == 2 && line.find(':') > 8) {
            in = a >= lo && a < hi;
            continue;
        }
        long kb = 0;
        if (in && std::sscanf(line.c_str(), "AnonHugePages: %ld kB", &kb) == 1)
            return kb;
    }
    return -1;
}

/// Under ASan or TSan the sanitizer's allocator maps (and reuses) the memory, not glibc's malloc:
/// what backs a buffer is its choice. Spelled out here rather than taken from
/// engine/testing/sanitizers.h as the other tests do: this test of a top-level engine header sits
/// below engine/testing/ in the layer order (scripts/check_layers.py).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitizerAllocator = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
constexpr bool kSanitizerAllocator = true;
#else
constexpr bool kSanitizerAllocator = false;
#endif
#else
constexpr bool kSanitizerAllocator = false;
#endif

TEST(HugePages, ALargeFreshBufferIsBackedByHugePagesWhereTheKernelOffersThem) {
    if (kSanitizerAllocator)
        GTEST_SKIP() << "a sanitizer's allocator maps this process's memory";
    const std::string mode = thp_mode();
    if (mode != "madvise")
        GTEST_SKIP() << "transparent huge pages are '" << mode
                     << "' here: the advice changes nothing ('always' backs every large buffer "
                        "with them, 'never' none)";
    std::vector<std::uint64_t> v;
    const std::size_t n = (std::size_t{64} << 20) / sizeof(std::uint64_t);  // 64 MiB
    reserve_fresh(v, n);
    v.assign(n, 1);
    const long kb = anon_huge_kb(reinterpret_cast<std::uintptr_t>(v.data() + n / 2));
    std::printf("AnonHugePages of the 64 MiB buffer: %ld kB (THP %s)\n", kb, mode.c_str());
    // Some of it at least (a fragmented machine may not find a free 2 MiB block for every
    // page; without the advice there is none).
    EXPECT_GE(kb, 2L << 10);
}

TEST(HugePages, SmallBuffersAreNotAdvised) {
    if (kSanitizerAllocator)
        GTEST_SKIP() << "a sanitizer's allocator maps this process's memory";
    const std::string mode = thp_mode();
    if (mode != "madvise")
        GTEST_SKIP() << "THP is '" << mode << "': a small buffer's pages are the kernel's choice";
    std::vector<std::uint64_t> v;
    const std::size_t n = (kHugePageMinBytes / 2) / sizeof(std::uint64_t);
    reserve_fresh(v, n);
    v.assign(n, 1);
    const long kb = anon_huge_kb(reinterpret_cast<std::uintptr_t>(v.data() + n / 2));
    EXPECT_LE(kb, 0L);
}

TEST(MappedAllocator, VectorsGrowCopyAndKeepTheirElements) {
    MappedVector<std::uint64_t> v;
    for (std::uint64_t i = 0; i < 100000; ++i)
        v.push_back(i * i);  // grows by reallocation, each block a mapping of its own
    const MappedVector<std::uint64_t> copy = v;
    v.resize(10);
    v.shrink_to_fit();
    ASSERT_EQ(copy.size(), 100000u);
    for (std::uint64_t i = 0; i < 100000; i += 997)
        EXPECT_EQ(copy[i], i * i);
    EXPECT_EQ(v.size(), 10u);
    EXPECT_EQ(v[9], 81u);
    MappedVector<int> none(0);  // no allocation, or one of a byte: either way valid
    none.reserve(0);
    EXPECT_TRUE(none.empty());
    MappedVector<int> zeros(5000);
    EXPECT_EQ(zeros[4999], 0);
    EXPECT_TRUE(MappedAllocator<int>{} == MappedAllocator<long>{});  // any frees any
    EXPECT_FALSE(MappedAllocator<int>{} != MappedAllocator<long>{});
}

#if defined(__GLIBC__)
TEST(MappedAllocator, AFreedArrayGivesItsPagesBackWhateverMallocsThresholds) {
    if (kSanitizerAllocator)
        GTEST_SKIP() << "a sanitizer's allocator maps this process's memory";
    if (process_resident_bytes() == 0)
        GTEST_SKIP() << "no /proc/self/statm to read the resident memory from";
    // The thresholds glibc moves to after a scene build has freed a large block (its mmap
    // threshold raised to that block's size, the trim threshold to twice it), set here outright.
    // A threshold set by mallopt stays fixed for the rest of the process (glibc no longer moves
    // it): ctest runs each test in a process of its own; in a run of the whole binary the tests
    // after this one run with the fixed thresholds set at its end, which changes no answer.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 256 << 20);
    // Free heap the earlier tests of a whole-binary run left resident would take the control's
    // block without growing the resident set (a helper's review: 15 of its 24 MiB).
    malloc_trim(0);
    constexpr std::size_t kBytes = std::size_t{24} << 20;
    constexpr std::size_t kMost = std::size_t{20} << 20;
    // The control: a vector of the same size, freed, stays in the heap and resident. Without it
    // the test could not tell the allocator apart from malloc.
    std::size_t before = process_resident_bytes();
    {
        std::vector<char> heap(kBytes, 1);
        // Used, as far as the compiler knows: clang 14 at -O2 elides an allocation that is never
        // read (a helper's review), and the control would measure nothing.
        asm volatile("" : : "r"(heap.data()) : "memory");
        EXPECT_GE(process_resident_bytes(), before + kMost);
    }
    const std::size_t kept = process_resident_bytes();
    EXPECT_GE(kept, before + kMost) << "glibc gave back a freed heap block below its thresholds";
    before = kept;
    {
        MappedVector<char> mapped(kBytes, 1);
        EXPECT_GE(process_resident_bytes(), before + kMost);
    }
    EXPECT_LT(process_resident_bytes(), before + (std::size_t{4} << 20));
    malloc_trim(0);  // the control's block
    mallopt(M_MMAP_THRESHOLD, 128 << 10);
    mallopt(M_TRIM_THRESHOLD, 128 << 10);
}
#endif

}  // namespace
}  // namespace raycastd::engine
