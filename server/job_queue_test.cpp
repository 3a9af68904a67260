#include "server/job_queue.h"

#include <atomic>
#include <chrono>
#include <thread>

#include <gtest/gtest.h>

namespace raycastd::server {
namespace {

using namespace std::chrono_literals;

/// Waits (up to 10 s) until the job reaches a finished state.
JobInfo wait_finished(const JobQueue& q, const std::string& id) {
    for (int i = 0; i < 1000; ++i) {
        auto info = q.info(id);
        if (info && info->finished)
            return *info;
        std::this_thread::sleep_for(10ms);
    }
    ADD_FAILURE() << "job " << id << " did not finish";
    return {};
}

/// A work item that "renders" `tiles` tiles, one per `step`, honouring cancel; it waits for
/// `gate` before starting so tests can look at a queued or running job.
JobQueue::Work tiles_work(int tiles, std::atomic<bool>* gate, std::chrono::milliseconds step) {
    return [=](engine::RenderProgress& p, const engine::CancelToken& cancel) {
        while (gate && !gate->load())
            std::this_thread::sleep_for(1ms);
        p.tiles_total = static_cast<std::size_t>(tiles);
        for (int i = 0; i < tiles && !cancel.cancelled(); ++i) {
            std::this_thread::sleep_for(step);
            ++p.tiles_done;
        }
        return JobOutput{"image", "image/png", {{"X-Rays", "primary=1"}}};
    };
}

TEST(JobQueue, RunsAJobToTheEndWithRealProgress) {
    JobQueue q(4, 8);
    std::atomic<bool> gate{false};
    auto id = q.submit(tiles_work(4, &gate, 20ms));
    ASSERT_TRUE(id);
    EXPECT_EQ(id->rfind("jb_", 0), 0u);
    EXPECT_EQ(id->size(), 3u + 16u);
    gate = true;
    // While running, progress is a fraction of tiles and only grows.
    double last = 0.0;
    for (int i = 0; i < 200; ++i) {
        auto info = q.info(*id);
        ASSERT_TRUE(info);
        EXPECT_GE(info->progress, last);
        last = info->progress;
        if (info->state == JobState::done)
            break;
        std::this_thread::sleep_for(5ms);
    }
    const JobInfo done = wait_finished(q, *id);
    EXPECT_EQ(done.state, JobState::done);
    EXPECT_EQ(done.progress, 1.0);
    EXPECT_EQ(done.tiles_done, 4u);
    ASSERT_TRUE(done.output);
    EXPECT_EQ(done.output->body, "image");
}

// A render that reports camera samples (RenderProgress::samples_*) is measured by them, not by
// its tiles: an adaptive render's first pass is half its tiles but a fraction of its samples.
TEST(JobQueue, ProgressInSamplesWhenTheRenderCountsThem) {
    JobQueue q(4, 8);
    std::atomic<bool> release{false}, reported{false};
    auto id = q.submit([&](engine::RenderProgress& p, const engine::CancelToken&) {
        p.tiles_total = 4;
        p.tiles_done = 2;
        p.samples_total = 1000;
        p.samples_done = 250;
        reported = true;
        while (!release.load())
            std::this_thread::sleep_for(1ms);
        return JobOutput{"image", "image/png", {}};
    });
    ASSERT_TRUE(id);
    while (!reported.load())
        std::this_thread::sleep_for(1ms);
    const auto info = q.info(*id);
    ASSERT_TRUE(info);
    EXPECT_EQ(info->progress, 0.25);
    EXPECT_EQ(info->tiles_done, 2u);
    release = true;
    EXPECT_EQ(wait_finished(q, *id).progress, 1.0);
}

TEST(JobQueue, EtaFromTheRateSoFar) {
    JobQueue q(4, 8);
    auto id = q.submit(tiles_work(10, nullptr, 30ms));
    ASSERT_TRUE(id);
    std::optional<JobInfo> info;
    for (int i = 0; i < 200; ++i) {
        info = q.info(*id);
        if (info->tiles_done >= 2)
            break;
        std::this_thread::sleep_for(5ms);
    }
    ASSERT_TRUE(info->eta_s);
    EXPECT_GT(*info->eta_s, 0.0);
    q.cancel_or_remove(*id);
}

TEST(JobQueue, CancelRunningAndQueued) {
    JobQueue q(4, 8);
    std::atomic<bool> gate{false};
    auto running = q.submit(tiles_work(1000, &gate, 1ms));
    auto queued = q.submit(tiles_work(1, nullptr, 1ms));
    ASSERT_TRUE(running && queued);
    EXPECT_EQ(q.info(*queued)->state, JobState::queued);
    EXPECT_EQ(q.cancel_or_remove(*queued), JobState::cancelled);
    EXPECT_EQ(q.info(*queued)->state, JobState::cancelled);
    gate = true;
    std::this_thread::sleep_for(20ms);
    EXPECT_EQ(q.cancel_or_remove(*running), JobState::cancelled);
    const JobInfo r = wait_finished(q, *running);
    EXPECT_EQ(r.state, JobState::cancelled);
    EXPECT_LT(r.tiles_done, 1000u);
    EXPECT_FALSE(r.output);
    // A finished job is forgotten by a second DELETE.
    EXPECT_EQ(q.cancel_or_remove(*running), JobState::cancelled);
    EXPECT_FALSE(q.info(*running));
    EXPECT_FALSE(q.cancel_or_remove("jb_nope"));
}

TEST(JobQueue, FullQueueIsBusy) {
    JobQueue q(2, 8);
    std::atomic<bool> gate{false};
    auto a = q.submit(tiles_work(1, &gate, 1ms));
    auto b = q.submit(tiles_work(1, &gate, 1ms));
    EXPECT_TRUE(a && b);
    EXPECT_FALSE(q.submit(tiles_work(1, &gate, 1ms)));
    gate = true;
    wait_finished(q, *a);
    wait_finished(q, *b);
    EXPECT_TRUE(q.submit(tiles_work(1, nullptr, 1ms)));
}

TEST(JobQueue, FailedJobKeepsItsError) {
    JobQueue q(2, 8);
    auto id = q.submit([](engine::RenderProgress&, const engine::CancelToken&) -> JobOutput {
        throw ApiError(ErrorCode::too_large, "no room");
    });
    const JobInfo info = wait_finished(q, *id);
    EXPECT_EQ(info.state, JobState::failed);
    ASSERT_TRUE(info.error);
    EXPECT_EQ(info.error->code, ErrorCode::too_large);
}

TEST(JobQueue, OldFinishedJobsAreDropped) {
    JobQueue q(8, 2);
    std::vector<std::string> ids;
    for (int i = 0; i < 4; ++i) {
        ids.push_back(*q.submit(tiles_work(1, nullptr, 1ms)));
        wait_finished(q, ids.back());
    }
    EXPECT_FALSE(q.info(ids[0]));
    EXPECT_FALSE(q.info(ids[1]));
    EXPECT_TRUE(q.info(ids[3]));
}

/// A job whose output is `bytes` bytes of image.
JobQueue::Work image_of(std::size_t bytes) {
    return [bytes](engine::RenderProgress&, const engine::CancelToken&) {
        return JobOutput{std::string(bytes, 'p'), "image/png", {}};
    };
}

TEST(JobQueue, FinishedImagesOverTheByteBudgetForgetTheOldestFirst) {
    JobQueue q(8, 32, 250);
    std::vector<std::string> ids;
    for (int i = 0; i < 3; ++i) {
        ids.push_back(*q.submit(image_of(100)));
        wait_finished(q, ids.back());
    }
    // 300 bytes would be over 250: the oldest goes, the two newest stay.
    EXPECT_FALSE(q.info(ids[0]));
    ASSERT_TRUE(q.info(ids[1]));
    EXPECT_EQ(q.info(ids[1])->output->body.size(), 100u);
    EXPECT_TRUE(q.info(ids[2]));
    EXPECT_EQ(q.counts().image_bytes, 200u);
    EXPECT_EQ(q.counts().evicted, 1u);
    // Deleting a finished job gives its bytes back.
    EXPECT_EQ(q.cancel_or_remove(ids[1]), JobState::done);
    EXPECT_EQ(q.counts().image_bytes, 100u);
}

TEST(JobQueue, TheNewestImageStaysWhateverItsSize) {
    JobQueue q(8, 32, 250);
    const std::string small = *q.submit(image_of(10));
    wait_finished(q, small);
    const std::string big = *q.submit(image_of(1000));
    wait_finished(q, big);
    EXPECT_FALSE(q.info(small)) << "older jobs make room for the newest";
    ASSERT_TRUE(q.info(big));
    EXPECT_EQ(q.info(big)->state, JobState::done);
    EXPECT_EQ(q.counts().image_bytes, 1000u);
}

TEST(JobQueue, DestructorStopsARunningJob) {
    std::atomic<bool> gate{true};
    auto q = std::make_unique<JobQueue>(2, 2);
    q->submit(tiles_work(100000, &gate, 1ms));
    std::this_thread::sleep_for(10ms);
    const auto start = std::chrono::steady_clock::now();
    q.reset();
    EXPECT_LT(std::chrono::steady_clock::now() - start, 2s);
}

}  // namespace
}  // namespace raycastd::server
