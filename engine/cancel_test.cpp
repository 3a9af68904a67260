#include "engine/cancel.h"

#include <atomic>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

using namespace std::chrono_literals;

TEST(CancelToken, DefaultNeverFires) {
    const CancelToken t;
    EXPECT_FALSE(t.can_fire());
    EXPECT_FALSE(t.cancelled());
    EXPECT_FALSE(t.fired());
    EXPECT_EQ(t.reason(), CancelToken::Reason::none);
    EXPECT_TRUE(t.status().ok());
}

TEST(CancelToken, CancelIsSeenByEveryCopyAndStays) {
    const CancelToken t = CancelToken::make();
    const CancelToken copy = t;
    EXPECT_TRUE(t.can_fire());
    EXPECT_FALSE(copy.cancelled());
    t.cancel();
    EXPECT_TRUE(copy.fired());
    EXPECT_TRUE(copy.cancelled());
    EXPECT_EQ(copy.reason(), CancelToken::Reason::cancelled);
    EXPECT_EQ(copy.status().code, Code::cancelled);
}

TEST(CancelToken, DeadlineFiresOnTheCheckAfterIt) {
    const CancelToken past = CancelToken::make(CancelToken::Clock::now() - 1ms);
    EXPECT_FALSE(past.fired());  // fired() does not look at the clock
    EXPECT_TRUE(past.cancelled());
    EXPECT_TRUE(past.fired());
    EXPECT_EQ(past.reason(), CancelToken::Reason::deadline);
    // The first reason stays.
    past.cancel();
    EXPECT_EQ(past.reason(), CancelToken::Reason::deadline);
    const CancelToken future = CancelToken::make(CancelToken::Clock::now() + 1h);
    EXPECT_FALSE(future.cancelled());
}

TEST(CancelToken, PollIsAskedAtMostOncePerIntervalAndNotAtFirst) {
    std::atomic<int> polls{0};
    std::atomic<bool> stop{false};
    const CancelToken t = CancelToken::make(std::nullopt, [&] {
        ++polls;
        return stop.load();
    });
    // Short work never pays for the callback.
    for (int i = 0; i < 1000; ++i)
        EXPECT_FALSE(t.cancelled());
    EXPECT_EQ(polls.load(), 0);
    std::this_thread::sleep_for(CancelToken::kPollInterval + 2ms);
    // Many threads checking at once: one of them polls.
    std::vector<std::thread> threads;
    for (int k = 0; k < 4; ++k) {
        threads.emplace_back([&] {
            for (int i = 0; i < 1000; ++i)
                t.cancelled();
        });
    }
    for (auto& th : threads)
        th.join();
    EXPECT_GE(polls.load(), 1);
    EXPECT_LE(polls.load(), 2);  // the loop may straddle a second interval on a slow machine
    stop = true;
    std::this_thread::sleep_for(CancelToken::kPollInterval + 2ms);
    EXPECT_TRUE(t.cancelled());
    EXPECT_EQ(t.reason(), CancelToken::Reason::polled);
}

}  // namespace
}  // namespace raycastd::engine
