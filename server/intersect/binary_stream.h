#pragma once
// A binary closest/any request traced while its body is still arriving, and answered while
// its last rays are still being traced.
//
// A 1M-ray float32 request moves 32 MB in and 32 MB out. Its body arrives through cpp-httplib's
// 4 KB reads on one server thread (~55 ms), and the answer leaves at the pace the client reads
// it (~55 ms for curl); traced in between, the batch costs another 60-90 ms on both cores,
// during which the connection is idle (docs/benchmarks.md). Here the batch is cut into chunks
// of kChunkRays rays:
//   - records are checked by the request thread as their bytes arrive (still in cache), and a
//     chunk is traced by a TBB task as soon as its bytes are in, while the request thread goes
//     on reading;
//   - once the whole body has arrived and every ray has passed the checks, the answer starts:
//     the response writer takes the chunks in order, tracing a chunk itself (on every core)
//     when no task has started it yet; while a task traces the chunk it is to write next, it
//     traces later chunks nobody has begun (TBB has one worker thread on two cores, so waiting
//     would leave a core idle), and it writes each chunk as soon as it is traced.
// Chunks start at multiples of QueryEngine::kBlockRays, so the answers are exactly those of the
// whole-batch path (binary_batch.h; both trace through intersect_records); a bad ray anywhere still
// makes the whole request invalid_ray naming the lowest bad index, before any answer is sent. A
// chunk's encoded answer is sized when its bytes have arrived (from buffers the scratch keeps
// between requests), so memory follows what the client has sent, not what its Content-Length
// promises. The options' CancelToken (server/request_cancel.h) is asked by each chunk before it
// is traced, by each of its blocks, and by the writer before each chunk: once it fires, work not
// begun is skipped and the answer is cut at the next chunk (the connection closes mid-answer).

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <memory>
#include <mutex>
#include <vector>

#include <tbb/task_group.h>

#include "engine/query/intersect.h"
#include "server/schema/binary_codec.h"
#include "server/scratch.h"

namespace httplib {
struct Response;
}

namespace raycastd::server {

class StreamedBatch {
  public:
    /// Rays per chunk: a multiple of QueryEngine::kBlockRays; 2 MB of float32 records.
    static constexpr std::size_t kChunkRays = 64 * engine::QueryEngine::kBlockRays;

    /// A batch of `rays` records (already checked with ray_count) for `options.mode` closest
    /// or any. The body goes to scratch->body, reserved (not touched) for all of it up front so
    /// that running chunks can read what has arrived while more is appended; chunk buffers come
    /// from scratch->chunks.
    StreamedBatch(std::shared_ptr<const engine::QueryEngine> engine,
                  const engine::QueryOptions& options, Dtype dtype, std::size_t rays,
                  std::shared_ptr<Scratch> scratch);
    /// Makes chunks not yet started skip their work and waits for running ones (they use the
    /// scratch).
    ~StreamedBatch();
    StreamedBatch(const StreamedBatch&) = delete;
    StreamedBatch& operator=(const StreamedBatch&) = delete;

    /// Appends received bytes, checks the records they complete and starts every chunk they
    /// complete. False, and the batch is spoilt (finish() throws), when they would run past
    /// the announced length.
    bool append(const char* data, std::size_t len);
    /// After the last byte: invalid_ray for the lowest bad ray; invalid_request when the body
    /// ended short of, or ran past, its announced length. Tracing may still be going on when it
    /// returns.
    void finish();

    /// Bytes of the whole answer.
    std::size_t answer_bytes() const { return rays_ * record_; }
    /// Hands answer bytes [offset, offset + length), cut at the end of the chunk that holds
    /// `offset` (tracing that chunk first if needed), to `write`, and returns what `write`
    /// returned; false, with nothing written, if the chunk could not be traced. A failed write
    /// marks the scratch to be freed rather than pooled. For
    /// cpp-httplib's content provider, after finish(). Never throws.
    template <class Write>
    bool write_answer(std::size_t offset, std::size_t length, Write&& write) noexcept {
        try {
            const std::size_t c = offset / (kChunkRays * record_);
            const std::size_t begin = c * kChunkRays * record_;
            const std::size_t end =
                std::min({answer_bytes(), begin + kChunkRays * record_, offset + length});
            // Past the time limit (or with the client gone) the answer is cut before the next
            // chunk: its 200 status is already on its way.
            if (offset >= end || options_.cancel.cancelled() || !answer_chunk(c))
                return false;
            const bool ok = write(chunk_[c]->out.data() + (offset - begin), end - offset);
            // A failed write is a client that has gone with the answer half read, after the
            // tracing may have finished: its buffers are freed, not pooled (scratch.h).
            if (!ok)
                scratch_->discard = true;
            return ok;
        } catch (...) {
            return false;
        }
    }

    engine::Precision precision() const { return precision_; }
    engine::Mode mode() const { return options_.mode; }
    std::size_t rays() const { return rays_; }

  private:
    // A chunk's life once its bytes are in; tracing is claimed with a compare-and-swap by
    // whoever takes it (a task, or the writer).
    enum State : int { kWaiting, kTracing, kTraced, kFailed };
    std::size_t chunk_begin(std::size_t c) const { return c * kChunkRays; }
    std::size_t chunk_end(std::size_t c) const { return std::min(rays_, (c + 1) * kChunkRays); }
    /// Sizes chunk c's buffers (request thread, before anybody else touches the chunk).
    void prepare(std::size_t c);
    bool claim(std::size_t c, State from, State to);
    /// A task: traces chunk c unless somebody else has begun it, the answer was abandoned or a
    /// bad ray makes the answers useless.
    void trace_if_needed(std::size_t c);
    /// Traces chunk c and encodes its answers; kFailed if the engine threw (out of memory).
    void trace(std::size_t c);
    /// Traces chunk c if nobody has started it, else waits for whoever did. False if it failed.
    bool answer_chunk(std::size_t c);
    void set_state(std::size_t c, State s);

    std::shared_ptr<const engine::QueryEngine> engine_;
    engine::QueryOptions options_;
    Dtype dtype_;
    engine::Precision precision_;
    std::size_t rays_;
    std::size_t bytes_;
    std::size_t record_;  ///< bytes of one answer record
    std::shared_ptr<Scratch> scratch_;
    const char* body_ = nullptr;  ///< scratch_->body.data(), fixed by the reserve
    std::size_t chunks_;
    std::size_t started_ = 0;  ///< chunks prepared and handed to tasks (request thread only)
    std::size_t checked_ = 0;  ///< records checked as they arrived (request thread only)
    bool overrun_ = false;     ///< append() refused bytes past the announced length
    std::atomic<std::size_t> first_bad_;
    std::atomic<bool> abandoned_{false};     ///< set by the destructor: tasks not started skip
    std::unique_ptr<StreamChunk*[]> chunk_;  ///< chunk c's buffers, once prepared
    std::unique_ptr<std::atomic<int>[]> state_;
    std::mutex mutex_;  ///< with changed_: waits for traced chunks
    std::condition_variable changed_;
    tbb::task_group tasks_;
};

/// Sends the answer of a batch after its finish(): chunks are written as they are traced. The
/// response keeps the batch (and its scratch) and `slot` (App::extend_work_slot) until the
/// answer has been written.
void send_streamed_answer(std::shared_ptr<StreamedBatch> batch, std::shared_ptr<void> slot,
                          httplib::Response& res);

}  // namespace raycastd::server
