#include "engine/cancel.h"

#include <cassert>

namespace raycastd::engine {

CancelToken CancelToken::make(std::optional<Clock::time_point> deadline, Poll poll) {
    CancelToken t;
    t.state_ = std::make_shared<State>();
    t.state_->deadline = deadline;
    t.state_->poll = std::move(poll);
    t.state_->next_poll = (Clock::now() + kPollInterval).time_since_epoch().count();
    return t;
}

void CancelToken::fire(Reason why) const {
    assert(state_ && "cancel() on a token that cannot fire");
    if (!state_)
        return;
    int expected = kNone;
    state_->reason.compare_exchange_strong(expected, static_cast<int>(why));
}

bool CancelToken::check_sources() const {
    State& s = *state_;
    const Clock::time_point now = Clock::now();
    if (s.deadline && now >= *s.deadline) {
        fire(Reason::deadline);
        return true;
    }
    if (s.poll) {
        // One thread polls per interval: the one that moves next_poll on.
        Clock::rep due = s.next_poll.load(std::memory_order_relaxed);
        const Clock::rep t = now.time_since_epoch().count();
        if (t >= due &&
            s.next_poll.compare_exchange_strong(
                due, (now + kPollInterval).time_since_epoch().count(), std::memory_order_relaxed) &&
            s.poll()) {
            fire(Reason::polled);
            return true;
        }
    }
    return s.reason.load() != kNone;  // another thread may have fired it meanwhile
}

Status CancelToken::status() const {
    switch (reason()) {
        case Reason::none:
            return {};
        case Reason::cancelled:
            return Status::error(Code::cancelled, "the work was cancelled");
        case Reason::deadline:
            return Status::error(Code::cancelled, "the work ran past its deadline and was stopped");
        case Reason::polled:
            return Status::error(Code::cancelled, "the work was abandoned by its caller");
    }
    return {};
}

}  // namespace raycastd::engine
