#pragma once
// CancelToken: how long work (a render, a batch of rays, a ray tree, a scene build) learns that
// nobody wants its answer any more. It sits beside status.h, below every folder of the engine,
// and knows nothing of HTTP: the server builds one per request from the client's connection and
// the request time limit; a background job gets one its DELETE can fire.
//
// A token made by make() fires for one of three reasons, whichever comes first: cancel() on any
// copy, its deadline passing, or its poll callback returning true; a default token never fires
// and costs nothing (no allocation). Work asks cancelled() between units of a few hundred
// microseconds or more — once per render tile, once per 1,024-ray block — never per ray, and
// stops when it says so. The check is one test of a null pointer for a default token, a relaxed
// load for a token without deadline or callback, and a load plus a clock read (vDSO, ~20 ns)
// for the others; the poll callback
// (a non-blocking poll() system call in the server) runs at most once per kPollInterval over all
// threads, and not at all during the first kPollInterval, so short work never pays for it.
// Once fired a token stays fired, and every copy sees it: a copy is a shared handle.

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <optional>

#include "engine/status.h"

namespace raycastd::engine {

class CancelToken {
  public:
    using Clock = std::chrono::steady_clock;
    /// Asked (from any thread) whether the work should stop; must be cheap and must not block.
    using Poll = std::function<bool()>;
    /// Why a token fired.
    enum class Reason {
        none,       ///< it has not fired
        cancelled,  ///< cancel() was called
        deadline,   ///< its deadline passed
        polled,     ///< its poll callback said stop (the server: the client has gone)
    };
    /// The poll callback's period, and its delay after the token is made.
    static constexpr std::chrono::milliseconds kPollInterval{10};

    /// A token that never fires (cancel() must not be called on it): work runs to its end.
    CancelToken() = default;
    /// A token that fires on cancel(), at `deadline` (none: never), and when `poll` (empty:
    /// never) returns true.
    static CancelToken make(std::optional<Clock::time_point> deadline = std::nullopt,
                            Poll poll = {});
    /// False for a default token: work may skip setting up its checks.
    bool can_fire() const { return state_ != nullptr; }

    /// The check long work makes between units: true once the token has fired, for whatever
    /// reason (it may fire in this call: the deadline is compared and the callback polled).
    bool cancelled() const;
    /// True once the token has fired, without looking at the clock or polling: for code that
    /// has just seen work skip and asks why. Never true before some cancelled() returned true
    /// or cancel() was called.
    bool fired() const { return state_ && state_->reason.load() != kNone; }
    /// Fires a token of make() (any thread, any number of times; the first reason stays).
    void cancel() const { fire(Reason::cancelled); }
    Reason reason() const {
        return state_ ? static_cast<Reason>(state_->reason.load()) : Reason::none;
    }
    /// ok while the token has not fired; else Code::cancelled with a message saying why.
    Status status() const;

  private:
    static constexpr int kNone = static_cast<int>(Reason::none);
    struct State {
        std::atomic<int> reason{kNone};
        std::optional<Clock::time_point> deadline;
        Poll poll;
        std::atomic<Clock::rep> next_poll{0};  ///< time_since_epoch of the next allowed poll
    };
    void fire(Reason why) const;
    /// The slow half of cancelled(): the deadline and the callback.
    bool check_sources() const;

    std::shared_ptr<State> state_;
};

inline bool CancelToken::cancelled() const {
    if (!state_)
        return false;
    if (state_->reason.load(std::memory_order_relaxed) != kNone)
        return true;
    if (!state_->deadline && !state_->poll)
        return false;
    return check_sources();
}

}  // namespace raycastd::engine
