#include "server/job_queue.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <random>

namespace raycastd::server {

using Clock = std::chrono::steady_clock;

struct JobQueue::Job {
    std::string id;
    Work work;
    engine::RenderProgress progress;
    engine::CancelToken cancel = engine::CancelToken::make();
    JobState state = JobState::queued;  // guarded by JobQueue::mu_
    Clock::time_point started;
    Clock::time_point finished;
    std::optional<ApiError> error;
    std::shared_ptr<const JobOutput> output;
};

namespace {

/// Bytes a finished job's output holds (0 without one).
std::uint64_t output_bytes(const std::shared_ptr<const JobOutput>& out) {
    return out ? out->body.size() : 0;
}

std::string new_job_id() {
    // Unguessable enough that one client cannot stumble on another's job.
    static std::mutex mu;
    static std::mt19937_64 rng{std::random_device{}()};
    std::lock_guard<std::mutex> lock(mu);
    char buf[32];
    std::snprintf(buf, sizeof buf, "jb_%016llx", static_cast<unsigned long long>(rng()));
    return buf;
}

}  // namespace

const char* to_string(JobState s) {
    switch (s) {
        case JobState::queued:
            return "queued";
        case JobState::running:
            return "running";
        case JobState::done:
            return "done";
        case JobState::failed:
            return "failed";
        case JobState::cancelled:
            return "cancelled";
    }
    return "failed";
}

JobQueue::JobQueue(std::size_t max_pending, std::size_t max_kept, std::uint64_t max_kept_bytes)
    : max_pending_(std::max<std::size_t>(1, max_pending)),
      max_kept_(max_kept),
      max_kept_bytes_(max_kept_bytes) {
    worker_ = std::thread([this] { run(); });
}

JobQueue::~JobQueue() {
    {
        std::lock_guard<std::mutex> lock(mu_);
        stopping_ = true;
        for (auto& [id, job] : jobs_)
            job->cancel.cancel();
    }
    cv_.notify_all();
    worker_.join();
}

std::optional<std::string> JobQueue::submit(Work work) {
    auto job = std::make_shared<Job>();
    job->work = std::move(work);
    {
        std::lock_guard<std::mutex> lock(mu_);
        if (pending_ >= max_pending_)
            return std::nullopt;
        do {
            job->id = new_job_id();
        } while (jobs_.count(job->id));
        jobs_[job->id] = job;
        queue_.push_back(job);
        ++pending_;
    }
    cv_.notify_one();
    return job->id;
}

void JobQueue::run() {
    for (;;) {
        std::shared_ptr<Job> job;
        {
            std::unique_lock<std::mutex> lock(mu_);
            cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
            if (stopping_)
                return;
            job = queue_.front();
            queue_.pop_front();
            if (job->state == JobState::cancelled)
                continue;  // cancelled while queued
            job->state = JobState::running;
            job->started = Clock::now();
            ++running_;
        }
        std::shared_ptr<const JobOutput> output;
        std::optional<ApiError> error;
        try {
            output = std::make_shared<const JobOutput>(job->work(job->progress, job->cancel));
        } catch (const ApiError& e) {
            error = e;
        } catch (const std::bad_alloc&) {
            error = ApiError(ErrorCode::too_large, "out of memory while rendering");
        } catch (const std::exception& e) {
            std::fprintf(stderr, "raycastd: job %s failed: %s\n", job->id.c_str(), e.what());
            error = ApiError(ErrorCode::internal, "internal error in job " + job->id);
        }
        std::lock_guard<std::mutex> lock(mu_);
        job->finished = Clock::now();
        if (job->cancel.fired()) {
            job->state = JobState::cancelled;
        } else if (error) {
            job->state = JobState::failed;
            job->error = std::move(error);
        } else {
            job->state = JobState::done;
            job->output = std::move(output);
            kept_bytes_ += output_bytes(job->output);
        }
        job->work = nullptr;  // releases the scene it held
        --pending_;
        --running_;
        finished_.push_back(job->id);
        trim_finished();
    }
}

JobQueue::Counts JobQueue::counts() const {
    std::lock_guard<std::mutex> lock(mu_);
    return {pending_ - running_, running_, kept_bytes_, evicted_};
}

void JobQueue::trim_finished() {
    // The newest finished job stays whatever its size: its client is about to ask for it.
    while (finished_.size() > max_kept_ ||
           (kept_bytes_ > max_kept_bytes_ && finished_.size() > 1)) {
        auto it = jobs_.find(finished_.front());
        if (it != jobs_.end()) {
            kept_bytes_ -= output_bytes(it->second->output);
            jobs_.erase(it);
        }
        finished_.pop_front();
        ++evicted_;
    }
}

std::optional<JobInfo> JobQueue::info(const std::string& id) const {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = jobs_.find(id);
    if (it == jobs_.end())
        return std::nullopt;
    const Job& j = *it->second;
    JobInfo out;
    out.id = j.id;
    // A running job asked to stop reports cancelled at once; it ends at its next tile.
    out.state = j.state == JobState::running && j.cancel.fired() ? JobState::cancelled : j.state;
    out.finished = j.state != JobState::queued && j.state != JobState::running;
    out.tiles_done = j.progress.tiles_done.load();
    out.tiles_total = j.progress.tiles_total.load();
    if (j.state == JobState::done) {
        out.progress = 1.0;
        out.eta_s = 0.0;
    } else if (const std::size_t total = j.progress.samples_total.load(); total > 0) {
        // Camera samples, not tiles: an adaptive render's first pass over its tiles traces one
        // sample a pixel, its second the rest where they are needed.
        out.progress = std::min(
            1.0, static_cast<double>(j.progress.samples_done.load()) / static_cast<double>(total));
    } else if (out.tiles_total > 0) {
        out.progress = static_cast<double>(out.tiles_done) / static_cast<double>(out.tiles_total);
    }
    if (j.state != JobState::queued) {
        const Clock::time_point end = j.state == JobState::running ? Clock::now() : j.finished;
        out.elapsed_s = std::chrono::duration<double>(end - j.started).count();
    }
    if (out.state == JobState::running && out.progress > 0.0) {
        out.eta_s = out.elapsed_s * (1.0 - out.progress) / out.progress;
    }
    out.error = j.error;
    out.output = j.output;
    return out;
}

std::optional<JobState> JobQueue::cancel_or_remove(const std::string& id) {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = jobs_.find(id);
    if (it == jobs_.end())
        return std::nullopt;
    Job& j = *it->second;
    if (j.state == JobState::queued) {
        // The worker skips it; it counts as finished from now on.
        j.state = JobState::cancelled;
        j.cancel.cancel();
        j.work = nullptr;
        --pending_;
        finished_.push_back(id);
        trim_finished();
        return JobState::cancelled;
    }
    if (j.state == JobState::running) {
        j.cancel.cancel();  // the worker marks it cancelled when the render returns
        return JobState::cancelled;
    }
    const JobState state = j.state;
    kept_bytes_ -= output_bytes(j.output);
    jobs_.erase(it);
    finished_.erase(std::find(finished_.begin(), finished_.end(), id));
    return state;
}

}  // namespace raycastd::server
