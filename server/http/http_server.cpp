#include "server/http/http_server.h"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <arpa/inet.h>
#include <malloc.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include "server/api_error.h"

namespace raycastd::server {

namespace {

using Clock = std::chrono::steady_clock;

/// The socket of the request being served on this thread (ClientProbe), −1 elsewhere.
thread_local int t_current_sock = -1;

/// The answer lease of the request being served on this thread (HttpServer::answer_lease).
thread_local MemoryBudget::Lease t_answer_lease;

/// The body lease of the request being served on this thread (HttpServer::body_lease).
thread_local MemoryBudget::Lease t_body_lease;

/// What the connection loop knows of the request being served on this thread, for the
/// answer's head (HttpServer::finish_answer_head) and for whether the connection goes on.
struct ServedRequest {
    const std::uint64_t* consumed = nullptr;  ///< the connection's bytes read so far
    std::uint64_t end = 0;                    ///< where its head and Content-Length body end
    bool chunked = false;
    bool close = false;  ///< its answer said Connection: close
    /// Whether the whole request has been read, so that the next one starts where reading
    /// stopped. Never after a chunked body: cpp-httplib's chunk reader ends a body at a chunk
    /// not followed by CRLF and reports success, so what follows ('2\r\n{}X\r\nGET …') would be
    /// read as a request of its own (a helper's review of 75c8f90, which had kept such
    /// connections open).
    bool complete() const { return *consumed >= end && !chunked; }
};
thread_local ServedRequest* t_served = nullptr;

/// Reads are taken from the socket this many bytes at a time (cpp-httplib reads heads a byte
/// at a time and bodies 4 KiB at a time, so the stream buffers).
constexpr std::size_t kReadChunk = 64u << 10;

/// A large body or answer leaves glibc holding the freed pages; above this size they are handed
/// back (malloc_trim) after the request, so twelve 100 MB uploads do not leave 1.7 GB resident.
constexpr std::uint64_t kTrimAfterBodyBytes = 32u << 20;

/// poll() for `events` until `deadline`; the revents (0 on timeout).
short wait_for(int sock, short events, Clock::time_point deadline) {
    for (;;) {
        const auto left =
            std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
        pollfd p{sock, events, 0};
        const int ms = static_cast<int>(std::clamp<long long>(left, 0, 1'000'000));
        const int r = ::poll(&p, 1, ms);
        if (r < 0 && errno == EINTR)
            continue;
        return r > 0 ? p.revents : 0;
    }
}

void address_of(int sock, bool peer, std::string& ip, int& port) {
    sockaddr_storage a{};
    socklen_t len = sizeof(a);
    const int r = peer ? ::getpeername(sock, reinterpret_cast<sockaddr*>(&a), &len)
                       : ::getsockname(sock, reinterpret_cast<sockaddr*>(&a), &len);
    ip.clear();
    port = -1;
    if (r != 0)
        return;
    char buf[INET6_ADDRSTRLEN] = {};
    if (a.ss_family == AF_INET) {
        const auto* v4 = reinterpret_cast<const sockaddr_in*>(&a);
        ::inet_ntop(AF_INET, &v4->sin_addr, buf, sizeof(buf));
        port = ntohs(v4->sin_port);
    } else if (a.ss_family == AF_INET6) {
        const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&a);
        ::inet_ntop(AF_INET6, &v6->sin6_addr, buf, sizeof(buf));
        port = ntohs(v6->sin6_port);
    }
    ip = buf;
}

const char* reason_phrase(int status) {
    switch (status) {
        case 400:
            return "Bad Request";
        case 413:
            return "Content Too Large";
        case 414:
            return "URI Too Long";
        case 431:
            return "Request Header Fields Too Large";
        case 503:
            return "Service Unavailable";
        case 505:
            return "HTTP Version Not Supported";
        default:
            return "Error";
    }
}

/// Closes after an answer that left part of the request unread: stop sending, then drain
/// what the client still sends for a moment, so that the kernel does not answer the unread
/// bytes with a reset that would destroy the answer in flight (RFC 9112 §9.6).
void lingering_close(int sock) {
    ::shutdown(sock, SHUT_WR);
    const auto until = Clock::now() + std::chrono::milliseconds(500);
    char sink[16384];
    std::size_t drained = 0;
    while (drained < (4u << 20) && (wait_for(sock, POLLIN, until) & (POLLIN | POLLHUP))) {
        const ssize_t n = ::recv(sock, sink, sizeof(sink), 0);
        if (n <= 0)
            break;
        drained += static_cast<std::size_t>(n);
    }
    ::close(sock);
}

}  // namespace

bool ClientProbe::gone() const {
    if (sock_ < 0)
        return false;
    pollfd p{sock_, static_cast<short>(POLLRDHUP), 0};
    if (::poll(&p, 1, 0) <= 0)
        return false;
    return (p.revents & (POLLRDHUP | POLLHUP | POLLERR)) != 0;
}

void ClientProbe::hang_up() const {
    if (sock_ >= 0)
        ::shutdown(sock_, SHUT_RDWR);
}

// ---------------------------------------------------------------------------------------------

/// The Stream cpp-httplib reads requests from and writes answers to: a buffered socket with
/// an absolute read deadline (the head's or the body's) besides the per-read pause limit.
class HttpServer::ConnStream : public httplib::Stream {
  public:
    ConnStream(int sock, const ConnectionLimits& limits) : sock_(sock), limits_(limits) {}

    bool is_readable() const override {
        return off_ < buf_.size() || (wait_readable() & (POLLIN | POLLHUP)) != 0;
    }
    bool is_writable() const override {
        const short r = wait_for(sock_, POLLOUT, Clock::now() + limits_.write_timeout);
        // POLLHUP alone is a peer that shut its side down: still writable (a half-close).
        return (r & POLLOUT) && !(r & POLLERR);
    }
    ssize_t read(char* ptr, size_t size) override {
        if (off_ < buf_.size()) {
            const std::size_t n = std::min(size, buf_.size() - off_);
            std::memcpy(ptr, buf_.data() + off_, n);
            off_ += n;
            consumed_ += n;
            return static_cast<ssize_t>(n);
        }
        buf_.clear();
        off_ = 0;
        if (!(wait_readable() & (POLLIN | POLLHUP)))
            return -1;
        if (size >= kReadChunk) {
            const ssize_t got = recv_some(ptr, size);
            consumed_ += got > 0 ? static_cast<std::uint64_t>(got) : 0;
            return got;
        }
        buf_.resize(kReadChunk);
        const ssize_t got = recv_some(buf_.data(), kReadChunk);
        buf_.resize(got > 0 ? static_cast<std::size_t>(got) : 0);
        if (got <= 0)
            return got;
        return read(ptr, size);
    }
    ssize_t write(const char* ptr, size_t size) override {
        for (;;) {
            const short r = wait_for(sock_, POLLOUT, Clock::now() + limits_.write_timeout);
            if (!(r & POLLOUT) || (r & POLLERR))
                return -1;
            const ssize_t n = ::send(sock_, ptr, size, MSG_NOSIGNAL | MSG_DONTWAIT);
            if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR))
                continue;
            return n;
        }
    }
    void get_remote_ip_and_port(std::string& ip, int& port) const override {
        address_of(sock_, true, ip, port);
    }
    void get_local_ip_and_port(std::string& ip, int& port) const override {
        address_of(sock_, false, ip, port);
    }
    socket_t socket() const override { return sock_; }

    /// Appends what arrives by `deadline` to the buffer: false on timeout, end-of-file or error.
    bool fill(Clock::time_point deadline) {
        if (off_ > 0) {
            buf_.erase(0, off_);
            off_ = 0;
        }
        const short r = wait_for(sock_, POLLIN, deadline);
        if (!(r & (POLLIN | POLLHUP))) {
            timed_out_ = r == 0;
            return false;
        }
        const std::size_t at = buf_.size();
        buf_.resize(at + kReadChunk);
        const ssize_t got = recv_some(buf_.data() + at, kReadChunk);
        buf_.resize(at + (got > 0 ? static_cast<std::size_t>(got) : 0));
        return got > 0;
    }
    /// The bytes received and not yet read.
    std::string_view unread() const { return std::string_view(buf_).substr(off_); }
    /// Replaces `len` unread bytes at `at` (relative to unread()) with `with`.
    void replace_unread(std::size_t at, std::size_t len, const std::string& with) {
        buf_.replace(off_ + at, len, with);
    }
    void set_read_deadline(Clock::time_point t) { deadline_ = t; }
    /// Bytes handed to cpp-httplib by read() so far.
    std::uint64_t consumed() const { return consumed_; }
    const std::uint64_t& consumed_ref() const { return consumed_; }
    bool timed_out() const { return timed_out_; }
    /// Set when an answer was sent before the whole request was read (close with lingering).
    bool linger = false;

  private:
    short wait_readable() const {
        const Clock::time_point until = std::min(deadline_, Clock::now() + limits_.read_timeout);
        const short r = wait_for(sock_, POLLIN, until);
        if (!r)
            timed_out_ = true;
        return r;
    }
    ssize_t recv_some(char* p, std::size_t n) {
        for (;;) {
            const ssize_t got = ::recv(sock_, p, n, 0);
            if (got < 0 && errno == EINTR)
                continue;
            return got;
        }
    }

    int sock_;
    const ConnectionLimits& limits_;
    std::string buf_;
    std::size_t off_ = 0;
    std::uint64_t consumed_ = 0;
    Clock::time_point deadline_ = Clock::time_point::max();
    mutable bool timed_out_ = false;
};

// ---------------------------------------------------------------------------------------------

HttpServer::HttpServer(ConnectionLimits limits)
    : limits_(std::move(limits)), bodies_(limits_.body_budget_bytes) {
    const std::size_t threads = limits_.max_connections;
    new_task_queue = [this, threads] {
        return new ConnectionThreads(
            threads, [this] { return registry_.evict_oldest(); },
            [this] { registry_.close_all_evictable(); });
    };
    set_post_routing_handler(
        [this](const httplib::Request&, httplib::Response& res) { finish_answer_head(res); });
}

void HttpServer::finish_answer_head(httplib::Response& res) {
    // cpp-httplib adds it to HEAD answers; Range is never applied (RequestHead::rewritten).
    res.headers.erase("Accept-Ranges");
    // The library's own refusals (a request line it cannot parse) come before any handler.
    if (!res.has_header("X-Request-Id"))
        res.set_header("X-Request-Id", next_request_id());
    // The library says keep-alive unless the client asked to close; the loop closes the
    // connection after a request it has not read to its end, and the answer must say so.
    if (t_served && !t_served->complete())
        t_served->close = true;
    if (t_served && t_served->close) {
        res.headers.erase("Keep-Alive");
        res.set_header("Connection", "close");
    }
}

HttpServer::~HttpServer() = default;

int HttpServer::bind(const std::string& host, int port) {
    const int bound = port == 0 ? bind_to_any_port(host) : (bind_to_port(host, port) ? port : -1);
    // listen() again on a listening socket only changes its backlog (Linux, listen(2)).
    if (bound > 0)
        ::listen(svr_sock_, kListenBacklog);
    return bound;
}

ClientProbe HttpServer::current_client() {
    return ClientProbe(t_current_sock);
}

MemoryBudget::Lease& HttpServer::answer_lease() {
    return t_answer_lease;
}

MemoryBudget::Lease& HttpServer::body_lease() {
    return t_body_lease;
}

HttpServer::Stats HttpServer::stats() const {
    Stats s;
    s.open_connections = registry_.size();
    s.idle_connections = registry_.evictable();
    s.evictions = registry_.evictions();
    s.refused_heads = refused_heads_.load();
    s.busy_bodies = bodies_.refusals();
    s.timeouts = timeouts_.load();
    s.body_bytes_in_flight = bodies_.used();
    return s;
}

bool HttpServer::process_and_close_socket(socket_t sock) {
    const int one = 1;
    // Without TCP_NODELAY every small answer waits for the client's delayed ACK: 530 instead
    // of 36,000 requests/s over 16 keep-alive connections on the development machine.
    ::setsockopt(sock, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    std::string ip;
    int port = 0;
    address_of(sock, true, ip, port);
    const auto h = registry_.add(sock, ip, limits_.max_idle_per_client);
    ConnStream strm(sock, limits_);
    serve(strm, h);
    registry_.remove(h);
    if (strm.linger) {
        lingering_close(sock);
    } else {
        ::shutdown(sock, SHUT_RDWR);
        ::close(sock);
    }
    return true;
}

void HttpServer::serve(ConnStream& strm, ConnectionRegistry::Handle h) {
    for (std::size_t served = 0; served < limits_.max_requests_per_connection; ++served) {
        if (stopping() || registry_.evicted(h))
            return;
        // Between requests: evictable, and bounded by the idle (or, before the first request,
        // the header) timeout. A pipelined request may already be buffered.
        registry_.set_phase(h, ConnPhase::idle);
        const auto wait = served == 0 ? limits_.header_timeout : limits_.idle_timeout;
        if (strm.unread().empty() && !strm.fill(Clock::now() + wait))
            return;
        registry_.set_phase(h, ConnPhase::head);
        const auto head_deadline = Clock::now() + limits_.header_timeout;
        std::optional<std::size_t> end;
        while (!(end = find_head_end(strm.unread()))) {
            if (strm.unread().size() > limits_.head.max_head_bytes) {
                const HeadError e = oversized_head(strm.unread(), limits_.head);
                write_error(strm, e.status, e.code, e.message);
                return;
            }
            if (!strm.fill(head_deadline)) {
                if (strm.timed_out())
                    timeouts_.fetch_add(1);
                return;
            }
        }
        const HeadCheck check = check_request_head(strm.unread(), *end, limits_.head);
        if (!check.head) {
            write_error(strm, check.error.status, check.error.code, check.error.message);
            return;
        }
        const RequestHead& head = *check.head;
        std::size_t head_bytes = head.head_bytes;
        if (head.rewritten) {
            strm.replace_unread(0, head.head_bytes, *head.rewritten);
            head_bytes = head.rewritten->size();
        }
        // The body budget: admitted when it fits, or when nothing else is in flight. The lease
        // is bound even for no length, for a reader whose body outgrows it (body_lease()).
        const std::uint64_t body = head.content_length;
        auto granted = bodies_.try_acquire(body);
        if (!granted) {
            write_error(strm, 503, ErrorCode::busy,
                        "request bodies in flight are at the server's limit of " +
                            std::to_string(limits_.body_budget_bytes >> 20) + " MiB; retry shortly",
                        1);
            return;
        }
        t_body_lease = std::move(*granted);
        registry_.set_phase(h, ConnPhase::active);
        const auto body_time = std::chrono::milliseconds(static_cast<long long>(
            1000.0 * static_cast<double>(body) /
            static_cast<double>(std::max<std::uint64_t>(limits_.min_body_rate, 1))));
        strm.set_read_deadline(Clock::now() + limits_.body_grace + body_time);
        const bool last = served + 1 == limits_.max_requests_per_connection || stopping();
        bool closed = false;
        ServedRequest served_request;
        served_request.consumed = &strm.consumed_ref();
        served_request.end = strm.consumed() + head_bytes + body;
        served_request.chunked = head.chunked;
        t_served = &served_request;
        t_current_sock = strm.socket();
        const bool ok = process_request(strm, last, closed, nullptr);
        t_current_sock = -1;
        t_served = nullptr;
        // The answer has been written (or given up on): its memory is free.
        const std::uint64_t answered = t_answer_lease.bytes();
        t_answer_lease = MemoryBudget::Lease();
        // A handler may answer before it has read the whole body (503 busy on a streamed
        // binary batch): the rest of the body would then be read as the next request. Such a
        // connection ends here (its answer said nothing of keep-alive that the client may rely
        // on: RFC 9112 §9.6 lets a server close after any response; the answer said
        // Connection: close, finish_answer_head). So does every connection that carried a
        // chunked body (ServedRequest::complete).
        const bool body_unread = !served_request.complete() || served_request.close;
        if (body_unread)
            strm.linger = true;
        strm.set_read_deadline(Clock::time_point::max());
        const std::uint64_t received = std::max(body, t_body_lease.bytes());
        t_body_lease = MemoryBudget::Lease();
        if (std::max(received, answered) >= kTrimAfterBodyBytes)
            ::malloc_trim(0);
        if (strm.timed_out())
            timeouts_.fetch_add(1);
        if (!ok || closed || last || body_unread)
            return;
    }
}

void HttpServer::write_error(ConnStream& strm, int status, ErrorCode code,
                             const std::string& message, int retry_after_s) {
    if (status != 503)
        refused_heads_.fetch_add(1);
    strm.linger = true;
    const std::string body = error_body(ApiError(code, message));
    std::string out =
        "HTTP/1.1 " + std::to_string(status) + " " + reason_phrase(status) +
        "\r\nContent-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) +
        "\r\nConnection: close\r\nX-Request-Id: " + next_request_id() + "\r\n";
    if (retry_after_s > 0)
        out += "Retry-After: " + std::to_string(retry_after_s) + "\r\n";
    out += "\r\n" + body;
    std::size_t sent = 0;
    while (sent < out.size()) {
        const ssize_t n = strm.write(out.data() + sent, out.size() - sent);
        if (n <= 0)
            break;
        sent += static_cast<std::size_t>(n);
    }
}

}  // namespace raycastd::server
