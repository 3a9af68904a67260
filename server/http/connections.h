#pragma once
// Connections: who holds a connection thread, and which connection gives its thread up when a
// new one needs it. cpp-httplib serves a connection on one pool thread from accept to close,
// so with a fixed pool a few clients that connect and say nothing (or dribble a header line
// every few seconds) hold every thread, and /v1/health waits behind them: 64 such sockets
// delayed it by 88 s. Here a connection that is between requests or still sending its request
// head is *evictable*: when the threads are all taken, or one address holds too many such
// connections, the one waiting longest is shut down (its thread sees end-of-file and closes
// it), so a new client is served at once. A connection whose request is being read or answered
// is never evicted; its own read and write deadlines bound it (http_server.h).

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <list>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>

namespace raycastd::server {

/// What one connection is doing, for eviction.
enum class ConnPhase {
    idle,    ///< between requests, or before the first byte: evictable
    head,    ///< reading the request line and headers: evictable
    active,  ///< reading the body, running the handler or writing the answer: never evicted
};

/// The open connections; thread-safe. Eviction shuts a socket down under the registry's lock,
/// and a connection leaves the registry before its socket is closed, so an evicted descriptor
/// is never one that has been closed and reused.
class ConnectionRegistry {
  public:
    struct Entry {
        int sock = -1;
        std::string client;  ///< the peer's address
        ConnPhase phase = ConnPhase::idle;
        std::chrono::steady_clock::time_point since;  ///< when the phase began
        bool evicted = false;
    };
    using Handle = std::list<Entry>::iterator;

    /// Registers a connection from `client`. When that address already holds
    /// `max_evictable_per_client` evictable connections, the oldest of them is evicted first.
    Handle add(int sock, std::string client, std::size_t max_evictable_per_client);
    /// Removes it (before the socket is closed).
    void remove(Handle h);
    void set_phase(Handle h, ConnPhase p);
    /// Whether the registry shut this connection down to make room.
    bool evicted(Handle h) const;

    /// Evicts the evictable connection that has waited longest; false when there is none.
    bool evict_oldest();
    /// Evicts every evictable connection, and from now on every connection added (the server
    /// is stopping: connections between requests end at once, active ones after their answer).
    void close_all_evictable();

    std::size_t size() const;
    std::size_t evictable() const;
    std::uint64_t evictions() const;

  private:
    /// Shuts e down (under mu_).
    void evict_locked(Entry& e);

    mutable std::mutex mu_;
    std::list<Entry> entries_;
    std::uint64_t evictions_ = 0;
    bool closing_ = false;
};

/// cpp-httplib's task queue: one thread per connection, started on demand up to `max_threads`
/// and kept for reuse. When every thread is taken, enqueue() first asks `make_room` to evict a
/// waiting connection (ConnectionRegistry::evict_oldest), whose thread then takes the new one.
/// shutdown() calls `on_shutdown` (ConnectionRegistry::close_all_evictable) before it joins.
class ConnectionThreads : public httplib::TaskQueue {
  public:
    ConnectionThreads(std::size_t max_threads, std::function<bool()> make_room,
                      std::function<void()> on_shutdown);
    ~ConnectionThreads() override;

    void enqueue(std::function<void()> fn) override;
    void shutdown() override;

  private:
    void run();

    const std::size_t max_threads_;
    std::function<bool()> make_room_;
    std::function<void()> on_shutdown_;
    std::mutex mu_;
    std::condition_variable cv_;
    std::deque<std::function<void()>> jobs_;
    std::vector<std::thread> threads_;
    std::size_t idle_ = 0;
    bool stopping_ = false;
};

}  // namespace raycastd::server
