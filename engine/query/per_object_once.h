#pragma once
// What QueryEngine builds per object on first use rather than at registration (the winding-number
// trees of point_entry.cpp, the computed shading normals of shading_normals.cpp): one slot per
// object, filled at most once however many threads ask at the same time, and the bytes of the
// filled slots for memory_bytes().

#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
#include <vector>

#include <tbb/task_arena.h>

namespace raycastd::engine {

/// T has memory_bytes().
template <class T>
class PerObjectOnce {
  public:
    explicit PerObjectOnce(std::size_t objects) : once_(objects), items_(objects) {}

    /// Object i's item, made by build() (returning std::unique_ptr<const T>) by the first caller;
    /// the others wait for it.
    template <class Build>
    const T& get(std::size_t i, Build&& build) {
        std::call_once(once_[i], [&] {
            // Isolated: the first caller is often a task of a parallel batch (for_each_point),
            // and a builder that runs TBB work of its own (PointBvh's parallel subtrees) lets a
            // thread waiting in it take any queued task, such as another block of the batch.
            // That block would call get() again: on the thread that holds the flag it waits on
            // itself, and on a thread that stole part of the build it waits for the holder,
            // which waits for it (found in review; the same trap as QueryEngine's blocks,
            // intersect.cpp). Threads that arrive meanwhile wait on the flag.
            std::unique_ptr<const T> item = tbb::this_task_arena::isolate([&] { return build(); });
            bytes_ += item->memory_bytes();
            items_[i] = std::move(item);
        });
        return *items_[i];
    }
    /// The bytes of the items built so far.
    std::size_t memory_bytes() const { return bytes_.load(); }

  private:
    std::vector<std::once_flag> once_;
    std::vector<std::unique_ptr<const T>> items_;
    std::atomic<std::size_t> bytes_{0};
};

}  // namespace raycastd::engine
