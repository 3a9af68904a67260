#pragma once
// Buffers that a thread reuses from one batch to the next.
//
// Why: a render traces a tile's rays generation by generation, and each generation's batch had
// its vectors made fresh (camera rays, their hits, shadow rays, directions to the lights,
// colours). `resize` value-initialises every element it adds, and the batch then writes each
// element again: for the Duck at spp 4 an estimated 1.9 GB of stores a render that nothing
// read, and malloc and free around them (perf put the fills at 4-5% of the render). A buffer
// that keeps its size from one batch to the next is only written by the batch: the CPU time of
// `bench_render --povray none --scenes duck --precisions fast --runs 3` fell from 3,378-3,572
// to 3,200-3,327 ms (five alternating pairs, 2026-12-07), the Duck's image the same file.
//
// ThreadScratch<T> leases a T from the calling thread's own free list for one scope and gives it
// back at the scope's end. A lease, not one T per thread: while a thread waits inside a parallel
// loop (a batch traced in blocks, a BVH built on first use), TBB may hand it another tile, whose
// batches then lease another T rather than overwrite the one still in use below them on the
// stack. No lock: the list is the thread's own. What a thread keeps is bounded
// (ThreadScratch::kKeptBytes for all its Ts of one type together; beyond that a T given back is
// freed), and a render empties its calling thread's list when it returns (release_all).

#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

namespace raycastd::engine {

/// v's first n elements as slots for a batch to overwrite: v grows to at least n elements
/// (value-initialising only the ones it adds) and never shrinks, so a reused buffer is not filled
/// again. The caller keeps the batch's own count; elements past n are left over from earlier.
template <class T>
T* slots(std::vector<T>& v, std::size_t n) {
    if (v.size() < n)
        v.resize(n);
    return v.data();
}

/// Bytes held by v's allocation.
template <class T>
std::size_t capacity_bytes(const std::vector<T>& v) {
    return v.capacity() * sizeof(T);
}

/// A T leased from this thread's free list (a new one when it is empty) for the lease's
/// lifetime. T has a `std::size_t bytes() const` saying what its buffers hold.
template <class T>
class ThreadScratch {
  public:
    /// What one thread keeps of T between leases, all its Ts together; a T given back beyond
    /// that is freed. The Duck's render batches at spp 4 hold about 0.65 MiB each, one per
    /// depth of reflection.
    static constexpr std::size_t kKeptBytes = std::size_t{4} << 20;

    ThreadScratch() {
        Kept& kept = this_thread();
        if (kept.items.empty()) {
            item_ = std::make_unique<T>();
        } else {
            item_ = std::move(kept.items.back().first);
            kept.bytes -= kept.items.back().second;
            kept.items.pop_back();
        }
    }
    ~ThreadScratch() {
        Kept& kept = this_thread();
        const std::size_t bytes = item_->bytes();
        if (bytes > kKeptBytes - kept.bytes)
            return;  // freed with item_
        try {
            kept.items.emplace_back(std::move(item_), bytes);
            kept.bytes += bytes;
        } catch (...) {
            // Out of memory for the list's own growth: the T is freed instead of kept (item_
            // is left as it was when emplace_back throws).
        }
    }
    ThreadScratch(const ThreadScratch&) = delete;
    ThreadScratch& operator=(const ThreadScratch&) = delete;

    T& operator*() { return *item_; }
    T* operator->() { return item_.get(); }

    /// Frees the Ts this thread keeps (those leased out are not in the list, and are kept or
    /// freed when their leases end). A render calls it on its way out, so that a thread that
    /// asked for one render (an HTTP connection's) does not keep buffers until it exits; the
    /// task pool's threads keep theirs, up to kKeptBytes each.
    static void release_all() {
        Kept& kept = this_thread();
        kept.items.clear();
        kept.items.shrink_to_fit();
        kept.bytes = 0;
    }
    /// What this thread keeps of T between leases (the bytes() of the Ts in its list): what
    /// release_all() frees.
    static std::size_t kept_bytes() { return this_thread().bytes; }

  private:
    struct Kept {
        std::vector<std::pair<std::unique_ptr<T>, std::size_t>> items;  ///< with bytes() at return
        std::size_t bytes = 0;                                          ///< their sum
    };
    static Kept& this_thread() {
        thread_local Kept kept;
        return kept;
    }
    std::unique_ptr<T> item_;
};

}  // namespace raycastd::engine
