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
// stack. No lock: the list is the thread's own. A T whose buffers have grown beyond
// kKeptBytes (a batch of an unusually large tile, a high spp) is freed rather than kept, so a
// thread holds at most a few of these, each at most that size, between renders.

#include <cstddef>
#include <memory>
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
    /// A T that is kept for reuse only while bytes() is at most this.
    static constexpr std::size_t kKeptBytes = std::size_t{1} << 20;

    ThreadScratch() {
        std::vector<std::unique_ptr<T>>& free = free_list();
        if (free.empty()) {
            item_ = std::make_unique<T>();
        } else {
            item_ = std::move(free.back());
            free.pop_back();
        }
    }
    ~ThreadScratch() {
        if (item_->bytes() > kKeptBytes)
            return;  // freed with item_
        try {
            free_list().push_back(std::move(item_));
        } catch (...) {
            // Out of memory for the list's own growth: the T is freed instead of kept.
        }
    }
    ThreadScratch(const ThreadScratch&) = delete;
    ThreadScratch& operator=(const ThreadScratch&) = delete;

    T& operator*() { return *item_; }
    T* operator->() { return item_.get(); }

  private:
    static std::vector<std::unique_ptr<T>>& free_list() {
        thread_local std::vector<std::unique_ptr<T>> free;
        return free;
    }
    std::unique_ptr<T> item_;
};

}  // namespace raycastd::engine
