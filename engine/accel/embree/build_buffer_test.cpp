// BuildBuffer (build_buffer.h): its pages are resident until release() and gone after it, and
// the range is then mapped without access, so that a read Embree was not expected to make
// faults instead of reading another allocation's data.

#include "engine/accel/embree/build_buffer.h"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

namespace raycastd::engine::embree {
namespace {

/// How many of the pages of [p, p + bytes) are resident (mincore).
std::size_t resident_pages(const void* p, std::size_t bytes) {
    const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
    const std::size_t pages = (bytes + page - 1) / page;
    std::vector<unsigned char> in(pages);
    if (mincore(const_cast<void*>(p), bytes, in.data()) != 0)
        return static_cast<std::size_t>(-1);
    std::size_t n = 0;
    for (unsigned char c : in)
        n += c & 1u;
    return n;
}

/// The permissions /proc/self/maps gives the mapping holding `p` ("rw-p", "---p"), or "".
std::string permissions_of(const void* p) {
    const auto at = reinterpret_cast<std::uintptr_t>(p);
    std::ifstream maps("/proc/self/maps");
    std::string line;
    while (std::getline(maps, line)) {
        std::istringstream in(line);
        std::string range, perms;
        in >> range >> perms;
        const std::size_t dash = range.find('-');
        const std::uintptr_t lo = std::stoull(range.substr(0, dash), nullptr, 16);
        const std::uintptr_t hi = std::stoull(range.substr(dash + 1), nullptr, 16);
        if (at >= lo && at < hi)
            return perms;
    }
    return "";
}

TEST(BuildBuffer, ReleaseGivesItsPagesBackAndLeavesTheRangeWithoutAccess) {
    constexpr std::size_t kBytes = 1 << 20;
    BuildBuffer b(kBytes);
    ASSERT_NE(b.data(), nullptr);
    EXPECT_EQ(b.resident_bytes(), kBytes + 16);
    std::memset(b.data(), 0x5a, kBytes);  // Embree's build reads what the geometry wrote
    const std::size_t pages = resident_pages(b.data(), kBytes);
    EXPECT_EQ(pages, kBytes / static_cast<std::size_t>(sysconf(_SC_PAGESIZE)));
    EXPECT_EQ(permissions_of(b.data()).substr(0, 3), "rw-");

    b.release();
    EXPECT_EQ(b.resident_bytes(), 0u);
    EXPECT_EQ(resident_pages(b.data(), kBytes), 0u);
    EXPECT_EQ(permissions_of(b.data()).substr(0, 3), "---");
    b.release();  // a second release changes nothing
    EXPECT_EQ(resident_pages(b.data(), kBytes), 0u);
}

TEST(BuildBuffer, CarvesAlignedPiecesUpToItsSize) {
    // Every geometry of a scene in one mapping: a mapping each had cost a page each (8 KiB for a
    // lone triangle's 48 B) and a mapping count the system limits.
    const std::size_t sizes[] = {12, 36, 4096, 1, 100};
    std::size_t total = 0;
    for (std::size_t n : sizes)
        total += BuildBuffer::carved(n);
    BuildBuffer b(total);
    ASSERT_NE(b.data(), nullptr);
    char* expected = static_cast<char*>(b.data());
    for (std::size_t n : sizes) {
        void* p = b.carve(n);
        ASSERT_EQ(p, expected) << n;
        EXPECT_EQ(reinterpret_cast<std::uintptr_t>(p) % 16, 0u);
        std::memset(p, 1, n);
        expected += BuildBuffer::carved(n);
    }
    EXPECT_EQ(b.carve(1), nullptr) << "past its end";
    b.release();
    EXPECT_EQ(b.carve(0), nullptr) << "released";
}

TEST(BuildBuffer, MovesHandOverTheMappingOnce) {
    BuildBuffer a(4096);
    void* p = a.data();
    ASSERT_NE(p, nullptr);
    ASSERT_EQ(a.carve(100), p);
    BuildBuffer b(std::move(a));
    EXPECT_EQ(b.data(), p);
    EXPECT_EQ(a.data(), nullptr);  // NOLINT(bugprone-use-after-move): moved-from is empty
    // What was carved stays carved (a move that forgot it would hand the same bytes out twice).
    EXPECT_EQ(b.carve(16), static_cast<char*>(p) + BuildBuffer::carved(100));
    std::vector<BuildBuffer> many;
    many.push_back(std::move(b));
    many.emplace_back(4096);
    many.emplace_back(4096);  // the vector grows: its elements move, none is unmapped twice
    EXPECT_EQ(many[0].data(), p);
    EXPECT_EQ(permissions_of(p).substr(0, 3), "rw-");
}

}  // namespace
}  // namespace raycastd::engine::embree
