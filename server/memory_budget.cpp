#include "server/memory_budget.h"

#include <utility>

namespace raycastd::server {

struct MemoryBudget::Lease::State {
    explicit State(std::uint64_t l) : limit(l) {}
    const std::uint64_t limit;
    std::atomic<std::uint64_t> used{0};
    std::atomic<std::uint64_t> refusals{0};
};

MemoryBudget::MemoryBudget(std::uint64_t limit_bytes)
    : state_(std::make_shared<Lease::State>(limit_bytes)) {}

MemoryBudget::Lease::Lease(Lease&& other) noexcept
    : state_(std::move(other.state_)), bytes_(std::exchange(other.bytes_, 0)) {}

MemoryBudget::Lease& MemoryBudget::Lease::operator=(Lease&& other) noexcept {
    if (this != &other) {
        release();
        state_ = std::move(other.state_);
        bytes_ = std::exchange(other.bytes_, 0);
    }
    return *this;
}

bool MemoryBudget::Lease::resize(std::uint64_t bytes) {
    if (!state_)
        return false;
    std::uint64_t used = state_->used.load();
    for (;;) {
        // What the other leases hold: ours is part of `used`.
        const std::uint64_t others = used - bytes_;
        if (bytes > bytes_ && others > 0 && others + bytes > state_->limit) {
            state_->refusals.fetch_add(1);
            return false;
        }
        if (state_->used.compare_exchange_weak(used, others + bytes))
            break;
    }
    bytes_ = bytes;
    return true;
}

void MemoryBudget::Lease::release() {
    if (state_ && bytes_ > 0)
        state_->used.fetch_sub(bytes_);
    bytes_ = 0;
}

std::optional<MemoryBudget::Lease> MemoryBudget::try_acquire(std::uint64_t bytes) {
    Lease lease = empty_lease();
    if (!lease.resize(bytes))
        return std::nullopt;
    return lease;
}

MemoryBudget::Lease MemoryBudget::empty_lease() {
    return Lease(state_);
}

std::uint64_t MemoryBudget::limit() const {
    return state_->limit;
}

std::uint64_t MemoryBudget::used() const {
    return state_->used.load();
}

std::uint64_t MemoryBudget::refusals() const {
    return state_->refusals.load();
}

}  // namespace raycastd::server
