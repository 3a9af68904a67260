#include "engine/query/per_object_once.h"

#include <atomic>
#include <chrono>
#include <cstddef>
#include <memory>
#include <thread>

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace raycastd::engine {
namespace {

struct Item {
    std::size_t memory_bytes() const { return 100; }
};

TEST(PerObjectOnce, BuildsEachSlotOnceAndCountsItsBytes) {
    PerObjectOnce<Item> slots(3);
    std::atomic<int> builds{0};
    auto build = [&] {
        ++builds;
        return std::make_unique<const Item>();
    };
    tbb::parallel_for(0, 300, [&](int k) { slots.get(static_cast<std::size_t>(k % 2), build); });
    EXPECT_EQ(builds.load(), 2);
    EXPECT_EQ(slots.memory_bytes(), 200u);
    const Item* first = &slots.get(0, build);
    EXPECT_EQ(first, &slots.get(0, build));
    EXPECT_EQ(builds.load(), 2);
}

// The trap of a build that runs TBB work of its own while it is itself a task of a parallel loop
// that asks for the same slot: a thread waiting inside the build may take up another block of
// the outer loop, and that block's get() would wait on the flag its own thread holds (a hang).
// Here the outer blocks note that they run inside the build instead, so that the test fails
// rather than hangs; one block builds, the others sleep, so that free threads steal the build's
// inner tasks and the builder, waiting for them, looks for work (without the isolation every
// run re-entered, measured).
TEST(PerObjectOnce, AThreadInsideTheBuildTakesNoOtherTaskOfTheLoopAround) {
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 8);
    tbb::task_arena arena(8);
    thread_local bool inside_build = false;
    std::atomic<int> reentered{0}, stolen{0};
    for (int run = 0; run < 5; ++run) {
        PerObjectOnce<Item> slots(1);
        auto build = [&] {
            inside_build = true;
            tbb::parallel_for(tbb::blocked_range<int>(0, 64, 1),
                              [&](const tbb::blocked_range<int>&) {
                                  stolen += !inside_build;
                                  std::this_thread::sleep_for(std::chrono::microseconds(300));
                              });
            inside_build = false;
            return std::make_unique<const Item>();
        };
        arena.execute([&] {
            tbb::parallel_for(tbb::blocked_range<int>(0, 256, 1),
                              [&](const tbb::blocked_range<int>& r) {
                                  if (inside_build) {
                                      ++reentered;
                                      return;
                                  }
                                  if (r.begin() == 0)
                                      slots.get(0, build);
                                  else
                                      std::this_thread::sleep_for(std::chrono::microseconds(100));
                              });
        });
    }
    EXPECT_EQ(reentered.load(), 0);
    // The trap needs the build's inner tasks to run on other threads (the builder then waits);
    // without that this test could not fail, so say so rather than pass.
    if (stolen.load() == 0)
        GTEST_SKIP() << "no inner task of the build ran on another thread: the scenario did not "
                        "happen on this machine";
}

}  // namespace
}  // namespace raycastd::engine
