#pragma once
// HttpServer: cpp-httplib's request parsing, routing and response writing, over raycastd's own
// connection loop. cpp-httplib 0.11.4 (Debian 12) lets a subclass replace the loop that serves
// one accepted socket (the private virtual process_and_close_socket) and call its request
// processing (the protected process_request) on a Stream of our own. The loop adds what the
// library lacks for a server on an open network:
//
//   * deadlines: a request head must arrive within header_timeout of its first byte, the next
//     request of a keep-alive connection within idle_timeout, a body at a bounded pace; a
//     slow client is dropped, not waited for;
//   * eviction (connections.h): connections waiting between requests or still sending a head
//     give up their thread to new clients, and one address holds a bounded number of them;
//   * framing checked before cpp-httplib sees it (request_head.h): malformed or contradictory
//     Content-Length, oversized URLs and heads get the API's JSON error and a closed
//     connection instead of a hang or a guess;
//   * a budget on request bodies in flight: a body that would take it over is refused with
//     503 busy and Retry-After before a byte of it is read, so many large uploads at once
//     cannot exhaust memory; the answer lease a handler takes (answer_lease(), App's answer
//     budget) is held until its answer has been written, then released here;
//   * a form-urlencoded Content-Type (what `curl -d` sends) is read as a plain body: the
//     library caps such bodies at 8 KiB (a compile-time constant of the Debian build), and no
//     raycastd endpoint takes a form;
//   * Range headers are dropped before the library sees them (RequestHead::rewritten): it cut
//     or multiplied any answer by them, and no raycastd answer is served in parts; no answer
//     says Accept-Ranges;
//   * an answer says Connection: close whenever the connection is to close after it (a body
//     left unread; any chunked body: the library's chunk reader takes a chunk not followed by
//     CRLF as the end, so the bytes after it would be read as the next request, a smuggled one),
//     and every answer,
//     the library's own refusals included, carries an X-Request-Id;
//   * a half-closed client (it shut down its sending side after the request) still gets its
//     answer: the library's writability test took end-of-file for a dead peer and dropped it;
//   * the peer of the request being served can be probed from any thread (ClientProbe), so
//     long work stops when its client has gone.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>

#include <httplib.h>

#include "server/http/connections.h"
#include "server/http/request_head.h"
#include "server/memory_budget.h"

namespace raycastd::server {

struct ConnectionLimits {
    std::size_t max_connections = 512;     ///< connections served at once (a thread each)
    std::size_t max_idle_per_client = 32;  ///< evictable connections one address may hold
    std::chrono::milliseconds header_timeout{10'000};  ///< first byte → end of the head
    std::chrono::milliseconds idle_timeout{5'000};     ///< keep-alive wait for the next request
    std::chrono::milliseconds read_timeout{10'000};    ///< longest pause within a body
    std::chrono::milliseconds write_timeout{30'000};   ///< longest stall writing an answer
    /// A body must arrive within body_grace + length / min_body_rate of its head.
    std::chrono::milliseconds body_grace{30'000};
    std::uint64_t min_body_rate = 256u << 10;  ///< bytes per second
    std::size_t max_requests_per_connection = 100'000;
    /// Request bodies (by Content-Length) being received or served at once; over it, 503 busy.
    /// One request alone is always admitted up to max_body_bytes.
    std::uint64_t body_budget_bytes = 2ull << 30;
    HeadLimits head;
};

/// Whether the client of one request is still there; cheap (one non-blocking poll) and usable
/// from any thread while that request is being served.
class ClientProbe {
  public:
    ClientProbe() = default;
    explicit ClientProbe(int sock) : sock_(sock) {}
    /// True once the client has closed or reset its connection (or half-closed it: a read-side
    /// end-of-file is taken as gone, as nginx takes it, since TCP cannot tell the two apart).
    /// False for a default-constructed probe.
    bool gone() const;
    /// Shuts the connection down in both directions, so that the answer of the request being
    /// served is not written (every write fails) and the connection closes after it: for a
    /// client that has gone, which would read no answer. The socket itself stays open until
    /// the connection loop closes it. Nothing for a default-constructed probe.
    void hang_up() const;

  private:
    int sock_ = -1;
};

class HttpServer : public httplib::Server {
  public:
    explicit HttpServer(ConnectionLimits limits);
    ~HttpServer() override;
    HttpServer(const HttpServer&) = delete;
    HttpServer& operator=(const HttpServer&) = delete;

    /// Binds to host:port (port 0: any free port) with a listen backlog of kListenBacklog;
    /// returns the port, or −1. cpp-httplib listens with a backlog of 5 (a compile-time constant
    /// of the Debian build), so a burst of new connections overflowed it and waited for SYN
    /// retransmissions (1 s, then 3 s) before being accepted.
    int bind(const std::string& host, int port);
    static constexpr int kListenBacklog = 1024;

    const ConnectionLimits& limits() const { return limits_; }
    /// The probe for the request served on the calling thread (a default probe elsewhere).
    static ClientProbe current_client();
    /// The answer lease of the request served on the calling thread (App::charge_answer): the
    /// connection loop releases it once that request's answer has been written (or has
    /// failed), streamed answers included. Unbound, and unused, on other threads.
    static MemoryBudget::Lease& answer_lease();
    /// The body lease of the request served on the calling thread: its Content-Length from the
    /// head to the answer's last byte, bound to the body budget (0 bytes for a chunked body),
    /// for a reader whose body outgrows it (a Content-Encoding inflates it, a chunked body has
    /// no length) to grow. Unbound on other threads.
    static MemoryBudget::Lease& body_lease();
    /// "rq_<n>": a fresh id for a response's X-Request-Id.
    std::string next_request_id() { return "rq_" + std::to_string(next_id_.fetch_add(1)); }

    struct Stats {
        std::size_t open_connections = 0;
        std::size_t idle_connections = 0;
        std::uint64_t evictions = 0;
        std::uint64_t refused_heads = 0;  ///< framing errors answered by this layer
        std::uint64_t busy_bodies = 0;    ///< bodies refused by the budget
        std::uint64_t timeouts = 0;       ///< connections dropped at a deadline
        std::uint64_t body_bytes_in_flight = 0;
    };
    Stats stats() const;

  private:
    class ConnStream;
    bool process_and_close_socket(socket_t sock) override;
    /// Serves requests on one connection until it closes; returns when the socket may close.
    void serve(ConnStream& strm, ConnectionRegistry::Handle h);
    /// Answers an error of this layer as JSON with Connection: close.
    void write_error(ConnStream& strm, int status, ErrorCode code, const std::string& message,
                     int retry_after_s = 0);
    /// The last word on an answer's head (the post-routing handler, so that a subclass or user
    /// must not replace it): no Accept-Ranges, an X-Request-Id, Connection: close when the
    /// connection will close after it.
    void finish_answer_head(httplib::Response& res);
    bool stopping() const { return svr_sock_ == INVALID_SOCKET; }

    ConnectionLimits limits_;
    ConnectionRegistry registry_;
    std::atomic<std::uint64_t> next_id_{1};
    MemoryBudget bodies_;  ///< request bodies by Content-Length, from head to answer
    std::atomic<std::uint64_t> refused_heads_{0}, timeouts_{0};
};

}  // namespace raycastd::server
