// ThreadScratch: a lease is reused by the next one on the same thread, leases alive at once are
// distinct (a tile TBB hands a waiting thread must not write over the one below it), each
// thread has its own, and an oversized one is freed rather than kept.

#include "engine/thread_scratch.h"

#include <thread>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

struct Buffers {
    std::vector<double> v;
    std::size_t bytes() const { return capacity_bytes(v); }
};

TEST(ThreadScratch, LeasesAreReusedAndNeverShared) {
    const Buffers* first = nullptr;
    {
        ThreadScratch<Buffers> a;
        first = &*a;
        double* p = slots(a->v, 100);
        p[99] = 7.0;
    }
    {
        ThreadScratch<Buffers> b;
        EXPECT_EQ(&*b, first);  // the same buffers, with their size and contents
        ASSERT_EQ(b->v.size(), 100u);
        EXPECT_EQ(b->v[99], 7.0);
        // slots() never shrinks and adds only what is missing.
        EXPECT_EQ(slots(b->v, 10), b->v.data());
        EXPECT_EQ(b->v.size(), 100u);
        slots(b->v, 150);
        EXPECT_EQ(b->v.size(), 150u);
        EXPECT_EQ(b->v[99], 7.0);
        EXPECT_EQ(b->v[149], 0.0);
        // A lease taken while b is held (a nested batch, or another tile run by this thread
        // while it waits) gets buffers of its own.
        ThreadScratch<Buffers> c;
        EXPECT_NE(&*c, &*b);
    }
    // Another thread has its own list.
    const Buffers* other = nullptr;
    std::thread([&] {
        ThreadScratch<Buffers> d;
        other = &*d;
        EXPECT_TRUE(d->v.empty());
    }).join();
    EXPECT_NE(other, first);
}

TEST(ThreadScratch, OversizedBuffersAreFreedNotKept) {
    {
        ThreadScratch<Buffers> a;
        ThreadScratch<Buffers> keep;  // held, so that the list has one left after a is dropped
        slots(a->v, ThreadScratch<Buffers>::kKeptBytes / sizeof(double) + 1);
    }
    // Both leases ended: `keep` went back to the list, a was freed. Two new leases at once
    // find one kept T and make another; neither holds a's oversized buffer.
    ThreadScratch<Buffers> x, y;
    EXPECT_LE(x->bytes(), ThreadScratch<Buffers>::kKeptBytes);
    EXPECT_LE(y->bytes(), ThreadScratch<Buffers>::kKeptBytes);
}

}  // namespace
}  // namespace raycastd::engine
