#pragma once
// RequestCancel: the engine's CancelToken (engine/cancel.h) for one HTTP request, and what its
// firing means for the answer.
//
// The token fires when the request's client has gone (HttpServer::current_client: it closed
// or reset its connection, or shut down its sending side) or when --request-timeout-s has
// passed since the handler began (after the body arrived; for a streamed binary batch, after
// the head). Work stops at its next tile, block or chunk and frees its buffers. Then:
//   * the client has gone: nobody will read an answer, so none is written: ClientGone is
//     thrown, and App::handle closes the connection;
//   * the time limit passed: 503 timeout, whose message names the limit. An answer whose 200
//     status is already on its way (a streamed binary batch) is cut instead: the connection
//     closes mid-answer, and the client sees a body shorter than its Content-Length.
// Async render jobs are not tied to their client and have no time limit: their token is the
// job's own, fired by DELETE /v1/jobs/{id} (job_queue.h).

#include <exception>
#include <string>

#include "engine/cancel.h"
#include "engine/status.h"
#include "server/api_error.h"
#include "server/config.h"

namespace raycastd::server {

/// Thrown when the client of a request has gone; App::handle answers nothing and closes.
struct ClientGone : std::exception {
    const char* what() const noexcept override { return "the client has gone"; }
};

class RequestCancel {
  public:
    /// For the request served on the calling thread (call it there, at the start of the
    /// handler): fires when its client has gone, or limits.request_timeout_s from now (0: no
    /// limit).
    static RequestCancel for_current_request(const Limits& limits);

    /// The token to put into the engine's options.
    const engine::CancelToken& token() const { return token_; }
    /// Returns when `st` is ok. Otherwise throws: when the token has fired, what that means
    /// for the request (stopped()); else the API error of the status (from_status with
    /// `path_prefix`).
    void check(const engine::Status& st, const std::string& path_prefix = {}) const;
    /// The same for a Result: returns its value when it has one.
    template <class T>
    const T& check(const engine::Result<T>& r) const {
        if (!r.ok())
            check(r.status());
        return r.value();
    }
    /// Throws what stopped() says once the token has fired (asking it now); returns otherwise.
    /// For work that reports no Status of its own.
    void throw_if_cancelled() const;
    /// Runs `work`, which throws ApiError for a Status of the engine (a scene build); once the
    /// token has fired, what it throws becomes what stopped() says.
    template <class Work>
    auto guard(Work&& work) const {
        try {
            return work();
        } catch (const ApiError&) {
            if (token_.fired())
                stopped();
            throw;
        }
    }
    /// What a fired token means: ClientGone when the client has gone, else ApiError timeout
    /// naming the limit.
    [[noreturn]] void stopped() const;

  private:
    RequestCancel(engine::CancelToken token, std::size_t timeout_s)
        : token_(std::move(token)), timeout_s_(timeout_s) {}
    engine::CancelToken token_;
    std::size_t timeout_s_;
};

}  // namespace raycastd::server
