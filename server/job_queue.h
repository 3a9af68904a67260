#pragma once
// JobQueue: long renders run in the background ("async": true). One worker thread takes jobs in
// order (each render already spreads over every core through TBB, so running two at once only
// splits the machine); at most `max_pending` jobs may wait or run (more is 503 busy). Finished
// jobs keep their output until deleted, or until more than `max_kept` have finished or their
// images together take more than `max_kept_bytes` (--job-budget-mb): then the oldest finished
// jobs are forgotten first (GET says job_not_found), but the newest one always stays, whatever
// the size of its image, so that the client polling for it can fetch it. Progress is the render's
// own count of tiles done. Each job has its own CancelToken (engine/cancel.h), fired by
// cancel_or_remove (DELETE /v1/jobs/{id}) and by the destructor; a job is not tied to the client
// that submitted it, and has no time limit.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "engine/render/render.h"
#include "server/api_error.h"

namespace raycastd::server {

enum class JobState { queued, running, done, failed, cancelled };
const char* to_string(JobState s);

/// What a finished job produced: an encoded image and the headers that go with it.
struct JobOutput {
    std::string body;
    std::string content_type;
    std::vector<std::pair<std::string, std::string>> headers;
};

/// A snapshot of one job.
struct JobInfo {
    std::string id;
    JobState state = JobState::queued;
    double progress = 0.0;        ///< tiles done / tiles (1 when done)
    std::optional<double> eta_s;  ///< seconds left, from the rate so far; none before a tile
    double elapsed_s = 0.0;       ///< since the job started running (0 while queued)
    std::size_t tiles_done = 0, tiles_total = 0;
    bool finished = false;          ///< the worker is done with it (a cancelled render has stopped)
    std::optional<ApiError> error;  ///< when failed
    std::shared_ptr<const JobOutput> output;  ///< when done
};

class JobQueue {
  public:
    /// The work of a job: renders with `progress` and `cancel` (the job's token, to put into the
    /// render's options) and returns its output; throws ApiError (or anything else: internal)
    /// to fail. A job whose token has fired ends cancelled, whatever its work returned.
    using Work = std::function<JobOutput(engine::RenderProgress& progress,
                                         const engine::CancelToken& cancel)>;

    JobQueue(std::size_t max_pending, std::size_t max_kept,
             std::uint64_t max_kept_bytes = UINT64_MAX);
    /// Cancels what is queued or running and waits for the worker.
    ~JobQueue();
    JobQueue(const JobQueue&) = delete;
    JobQueue& operator=(const JobQueue&) = delete;

    /// The new job's id ("jb_" + 16 hex digits), or nullopt when max_pending jobs are already
    /// queued or running.
    std::optional<std::string> submit(Work work);
    /// A snapshot, or nullopt for an unknown id.
    std::optional<JobInfo> info(const std::string& id) const;
    /// Queued or running: cancels it (state cancelled; a running render stops at its next
    /// tile). Already finished: forgets it. Returns the state after the call, nullopt when the
    /// id is unknown.
    std::optional<JobState> cancel_or_remove(const std::string& id);

    struct Counts {
        std::size_t queued = 0, running = 0;
        std::uint64_t image_bytes = 0;  ///< of the finished jobs' outputs kept now
        std::uint64_t evicted = 0;      ///< finished jobs forgotten to keep within the limits
    };
    /// Jobs waiting and rendering now, and the finished ones' memory (for GET /metrics).
    Counts counts() const;

  private:
    struct Job;
    void run();
    void trim_finished();  // with mu_ held

    const std::size_t max_pending_;
    const std::size_t max_kept_;
    const std::uint64_t max_kept_bytes_;
    mutable std::mutex mu_;
    std::condition_variable cv_;
    std::map<std::string, std::shared_ptr<Job>> jobs_;
    std::deque<std::shared_ptr<Job>> queue_;
    std::deque<std::string> finished_;  ///< ids in the order they finished
    std::size_t pending_ = 0;           ///< queued + running
    std::size_t running_ = 0;           ///< 0 or 1: one worker renders
    std::uint64_t kept_bytes_ = 0;      ///< output bytes of the finished jobs in jobs_
    std::uint64_t evicted_ = 0;
    bool stopping_ = false;
    std::thread worker_;
};

}  // namespace raycastd::server
