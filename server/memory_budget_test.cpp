#include "server/memory_budget.h"

#include <gtest/gtest.h>

namespace raycastd::server {
namespace {

TEST(MemoryBudget, GrantsWhatFitsAndRefusesWhatWouldGoOver) {
    MemoryBudget budget(1000);
    auto a = budget.try_acquire(600);
    ASSERT_TRUE(a);
    EXPECT_EQ(budget.used(), 600u);
    auto b = budget.try_acquire(400);
    ASSERT_TRUE(b) << "exactly at the limit fits";
    EXPECT_FALSE(budget.try_acquire(1)) << "one byte over";
    EXPECT_EQ(budget.refusals(), 1u);
    EXPECT_EQ(budget.used(), 1000u);
}

TEST(MemoryBudget, ALoneLeaseIsGrantedWhateverItsSize) {
    // A request within the --max-* limits must be servable on an idle server.
    MemoryBudget budget(1000);
    auto big = budget.try_acquire(5000);
    ASSERT_TRUE(big);
    EXPECT_EQ(budget.used(), 5000u);
    EXPECT_FALSE(budget.try_acquire(1));
    big.reset();
    EXPECT_EQ(budget.used(), 0u) << "a destroyed lease gives its bytes back";
    EXPECT_TRUE(budget.try_acquire(5000));
}

TEST(MemoryBudget, ResizeGrowsOnlyWithinTheLimitAndAlwaysShrinks) {
    MemoryBudget budget(1000);
    auto a = budget.try_acquire(300);
    auto b = budget.try_acquire(300);
    ASSERT_TRUE(a && b);
    EXPECT_TRUE(a->resize(700));
    EXPECT_EQ(budget.used(), 1000u);
    EXPECT_FALSE(a->resize(701));
    EXPECT_EQ(a->bytes(), 700u) << "a refused growth leaves the lease as it was";
    EXPECT_TRUE(a->resize(10));
    EXPECT_EQ(budget.used(), 310u);
    // Growing a lease counts what the others hold, not the lease itself.
    b->release();
    EXPECT_TRUE(a->resize(4000));
    EXPECT_EQ(budget.used(), 4000u);
}

TEST(MemoryBudget, AMovedLeaseIsReleasedOnce) {
    MemoryBudget budget(1000);
    MemoryBudget::Lease held;
    EXPECT_FALSE(held.bound());
    EXPECT_FALSE(held.resize(10)) << "an unbound lease holds nothing";
    {
        auto a = budget.try_acquire(250);
        ASSERT_TRUE(a);
        held = std::move(*a);
    }
    EXPECT_EQ(budget.used(), 250u);
    MemoryBudget::Lease other = std::move(held);
    EXPECT_EQ(held.bytes(), 0u);
    EXPECT_EQ(other.bytes(), 250u);
    other = MemoryBudget::Lease();
    EXPECT_EQ(budget.used(), 0u);
}

TEST(MemoryBudget, ALeaseOutlivingItsBudgetIsSafe) {
    std::optional<MemoryBudget::Lease> lease;
    {
        MemoryBudget budget(10);
        lease = budget.try_acquire(5);
    }
    ASSERT_TRUE(lease);
    lease->release();
    EXPECT_EQ(lease->bytes(), 0u);
}

}  // namespace
}  // namespace raycastd::server
