#pragma once
// MemoryBudget: a bound on the bytes that one kind of buffer holds across all requests at once
// (request bodies being received, answers being built or written). A request asks for a Lease
// of the bytes it will hold before it allocates them; a lease that would take the budget over
// its limit is refused, and the request is answered 503 busy with Retry-After instead of
// allocating. One lease alone is always granted (whatever the limit, a request within the
// --max-* limits is served when nothing else holds the budget), so the bound is
// max(limit, the largest single lease). Lock-free: one compare-and-swap per grant.

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>

namespace raycastd::server {

class MemoryBudget {
  public:
    /// A budget of `limit_bytes` (0: every lease but a lone one is refused).
    explicit MemoryBudget(std::uint64_t limit_bytes);

    /// Bytes held from a budget until the lease is released or destroyed. A default lease is
    /// bound to no budget and holds nothing; leases are move-only.
    class Lease {
      public:
        Lease() = default;
        ~Lease() { release(); }
        Lease(Lease&& other) noexcept;
        Lease& operator=(Lease&& other) noexcept;
        Lease(const Lease&) = delete;
        Lease& operator=(const Lease&) = delete;

        /// Bytes this lease holds.
        std::uint64_t bytes() const { return bytes_; }
        /// Whether the lease is bound to a budget.
        bool bound() const { return state_ != nullptr; }
        /// Holds `bytes` instead: shrinking always succeeds; growing fails (false, the lease
        /// unchanged, counted as a refusal) when what the other leases hold plus `bytes` is over
        /// the limit and the other leases hold anything at all. False for an unbound lease.
        bool resize(std::uint64_t bytes);
        /// Gives the bytes back; the lease stays bound, holding 0.
        void release();

      private:
        friend class MemoryBudget;
        struct State;
        explicit Lease(std::shared_ptr<State> state) : state_(std::move(state)) {}
        std::shared_ptr<State> state_;  ///< shared: a lease may outlive its budget's owner
        std::uint64_t bytes_ = 0;
    };

    /// A lease of `bytes`, or nullopt when it is refused (Lease::resize).
    std::optional<Lease> try_acquire(std::uint64_t bytes);
    /// A lease of 0 bytes bound to this budget, to be resized.
    Lease empty_lease();

    std::uint64_t limit() const;
    /// Bytes the leases hold now.
    std::uint64_t used() const;
    /// Leases refused (or growths refused) so far.
    std::uint64_t refusals() const;

  private:
    std::shared_ptr<Lease::State> state_;
};

}  // namespace raycastd::server
