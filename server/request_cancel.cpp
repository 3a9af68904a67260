#include "server/request_cancel.h"

#include <chrono>
#include <optional>

#include "server/http/http_server.h"

namespace raycastd::server {

RequestCancel RequestCancel::for_current_request(const Limits& limits) {
    std::optional<engine::CancelToken::Clock::time_point> deadline;
    if (limits.request_timeout_s > 0) {
        deadline = engine::CancelToken::Clock::now() +
                   std::chrono::seconds(static_cast<long long>(limits.request_timeout_s));
    }
    // The probe is only valid while this request is served; every user of the token (the
    // engine's work, a streamed answer's tasks) finishes before the request does.
    const ClientProbe probe = HttpServer::current_client();
    return RequestCancel(engine::CancelToken::make(deadline, [probe] { return probe.gone(); }),
                         limits.request_timeout_s);
}

void RequestCancel::check(const engine::Status& st, const std::string& path_prefix) const {
    if (st.ok())
        return;
    if (token_.fired())
        stopped();
    throw from_status(st, path_prefix);
}

void RequestCancel::throw_if_cancelled() const {
    if (token_.cancelled())
        stopped();
}

void RequestCancel::stopped() const {
    if (token_.reason() == engine::CancelToken::Reason::deadline) {
        throw ApiError(ErrorCode::timeout,
                       "the request ran past the server's time limit of " +
                           std::to_string(timeout_s_) + " s (--request-timeout-s " +
                           std::to_string(timeout_s_) + "); its work was cancelled");
    }
    throw ClientGone();
}

}  // namespace raycastd::server
