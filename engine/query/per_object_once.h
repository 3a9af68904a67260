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
            std::unique_ptr<const T> item = build();
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
