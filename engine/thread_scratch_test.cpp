// ThreadScratch: a lease is reused by the next one on the same thread, leases alive at once are
// distinct (a tile TBB hands a waiting thread must not write over the one below it), each
// thread has its own, what a thread keeps is bounded, and release_all frees it. Each test
// starts from an empty list (release_all), so that the tests hold in any order and repeated.

#include "engine/thread_scratch.h"

#include <thread>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

struct Buffers {
    std::vector<double> v;
    std::size_t bytes() const { return capacity_bytes(v); }
};
using Lease = ThreadScratch<Buffers>;

TEST(ThreadScratch, LeasesAreReusedAndNeverShared) {
    Lease::release_all();
    const Buffers* first = nullptr;
    std::size_t b_bytes = 0;
    {
        Lease a;
        first = &*a;
        EXPECT_TRUE(a->v.empty());
        double* p = slots(a->v, 100);
        p[99] = 7.0;
    }
    {
        Lease b;
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
        Lease c;
        EXPECT_NE(&*c, &*b);
        EXPECT_TRUE(c->v.empty());
        b_bytes = capacity_bytes(b->v);
    }
    // Another thread has its own list.
    std::thread([&] {
        Lease d;
        EXPECT_TRUE(d->v.empty());
    }).join();
    // kept_bytes counts what the thread keeps (b's allocation and c's none, given back), and
    // release_all frees it: the next lease starts empty.
    EXPECT_EQ(Lease::kept_bytes(), b_bytes);
    EXPECT_GE(b_bytes, 150 * sizeof(double));
    Lease::release_all();
    EXPECT_EQ(Lease::kept_bytes(), 0u);
    Lease e;
    EXPECT_TRUE(e->v.empty());
}

TEST(ThreadScratch, WhatAThreadKeepsIsBounded) {
    Lease::release_all();
    const std::size_t doubles = Lease::kKeptBytes / sizeof(double);
    {
        Lease a;  // grown beyond what a thread keeps: freed when given back
        slots(a->v, doubles + 1);
    }
    {
        Lease b;
        EXPECT_TRUE(b->v.empty());
    }
    {
        // Three of 40% each: two are kept, the third given back is freed.
        Lease x, y, z;
        slots(x->v, doubles * 2 / 5);
        slots(y->v, doubles * 2 / 5);
        slots(z->v, doubles * 2 / 5);
    }
    EXPECT_EQ(Lease::kept_bytes(), 2 * (doubles * 2 / 5) * sizeof(double));
    Lease p, q, r;
    const int kept = !p->v.empty() + !q->v.empty() + !r->v.empty();
    EXPECT_EQ(kept, 2);
    EXPECT_EQ(Lease::kept_bytes(), 0u);  // both leased out again
}

}  // namespace
}  // namespace raycastd::engine
