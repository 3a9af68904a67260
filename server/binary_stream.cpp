#include "server/binary_stream.h"

#include <string_view>

#include "server/api_error.h"

namespace raycastd::server {

static_assert(StreamedBatch::kChunkRays % engine::QueryEngine::kBlockRays == 0,
              "chunks must start on the engine's block boundaries");

StreamedBatch::StreamedBatch(std::shared_ptr<const engine::QueryEngine> engine,
                             const engine::QueryOptions& options, Dtype dtype, std::size_t rays,
                             std::shared_ptr<Scratch> scratch)
    : engine_(std::move(engine)),
      options_(options),
      dtype_(dtype),
      rays_(rays),
      bytes_(rays * ray_record_bytes(dtype)),
      scratch_(std::move(scratch)),
      chunks_((rays + kChunkRays - 1) / kChunkRays),
      first_bad_(rays),
      state_(new std::atomic<int>[chunks_]) {
    for (std::size_t c = 0; c < chunks_; ++c)
        state_[c] = kWaiting;
    Scratch& s = *scratch_;
    s.body.clear();
    s.body.reserve(bytes_);  // never reallocated below: chunks read it while it grows
    s.rays.resize(rays_);
    s.result.precision = engine_->effective_precision(options_.precision);
    s.result.offsets.clear();
    s.result.counts.clear();
    s.result.hits.resize(rays_);  // intersect_span writes every answer
    s.out.resize(answer_bytes());
}

StreamedBatch::~StreamedBatch() {
    tasks_.cancel();  // an abandoned answer needs no more tracing
    try {
        tasks_.wait();
    } catch (...) {
        // The request has failed already or its answer was abandoned; a chunk's own failure
        // adds nothing to that.
    }
}

bool StreamedBatch::append(const char* data, std::size_t len) {
    std::string& body = scratch_->body;
    if (len > bytes_ - body.size())
        return false;
    body.append(data, len);
    // Whole chunks only; finish() takes the last, partial one.
    const std::size_t arrived = body.size() / ray_record_bytes(dtype_);
    while (started_ < chunks_ && (started_ + 1) * kChunkRays <= arrived) {
        const std::size_t c = started_++;
        tasks_.run([this, c] { decode_and_trace(c); });
    }
    return true;
}

bool StreamedBatch::claim(std::size_t c, State from, State to) {
    int expected = from;
    return state_[c].compare_exchange_strong(expected, to);
}

void StreamedBatch::set_state(std::size_t c, State s) {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        state_[c] = s;
        if (s == kDecoded)
            ++decoded_;
    }
    changed_.notify_all();
}

void StreamedBatch::decode_and_trace(std::size_t c) {
    if (claim(c, kWaiting, kDecoding))
        decode(c);
    if (first_bad_.load() < rays_)
        return;  // the request is an error: no answers needed
    if (claim(c, kDecoded, kTracing))
        trace(c);
}

void StreamedBatch::decode(std::size_t c) {
    const std::size_t b = chunk_begin(c), e = chunk_end(c);
    // The whole announced length: data() is stable (reserved), and a chunk is decoded only
    // once all of its bytes have arrived.
    const std::string_view body(scratch_->body.data(), bytes_);
    const std::size_t bad = decode_ray_range(body, dtype_, b, e, scratch_->rays);
    if (bad < e) {
        std::size_t cur = first_bad_.load();
        while (bad < cur && !first_bad_.compare_exchange_weak(cur, bad)) {
        }
    }
    set_state(c, kDecoded);
}

void StreamedBatch::trace(std::size_t c) {
    const std::size_t b = chunk_begin(c), e = chunk_end(c);
    Scratch& s = *scratch_;
    try {
        engine_->intersect_span(s.rays.data() + b, e - b, options_, s.result.hits.data() + b);
    } catch (...) {
        set_state(c, kFailed);  // the writer gives up on the answer; the client sees it cut
        return;
    }
    encode_answers(s.result.hits.data(), options_.mode, dtype_, b, e, s.out.data());
    set_state(c, kTraced);
}

void StreamedBatch::finish() {
    const std::size_t got = scratch_->body.size();
    if (got != bytes_) {
        throw api_error("invalid_request", "body ended after " + std::to_string(got) + " of " +
                                               std::to_string(bytes_) + " announced bytes");
    }
    // Every ray must pass the checks before the answer starts (its status is 200). This thread
    // decodes what no task has begun, the partial last chunk included (~1 ms a chunk), rather
    // than wait for tasks queued behind chunks being traced.
    for (std::size_t c = 0; c < chunks_; ++c) {
        if (claim(c, kWaiting, kDecoding))
            decode(c);
    }
    started_ = chunks_;
    {
        std::unique_lock<std::mutex> lock(mutex_);
        changed_.wait(lock, [this] { return decoded_ == chunks_; });
    }
    if (const std::size_t i = first_bad_.load(); i < rays_) {
        tasks_.wait();  // no task may still read the rays
        throw_invalid_ray(scratch_->rays[i], i);
    }
}

bool StreamedBatch::answer_chunk(std::size_t c) {
    if (claim(c, kDecoded, kTracing))
        trace(c);
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [this, c] { return state_[c].load() >= kTraced; });
    return state_[c].load() == kTraced;
}

}  // namespace raycastd::server
