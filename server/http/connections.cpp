#include "server/http/connections.h"

#include <sys/socket.h>

namespace raycastd::server {

namespace {

bool is_evictable(const ConnectionRegistry::Entry& e) {
    return !e.evicted && e.phase != ConnPhase::active;
}

}  // namespace

ConnectionRegistry::Handle ConnectionRegistry::add(int sock, std::string client,
                                                   std::size_t max_evictable_per_client) {
    std::lock_guard<std::mutex> lock(mu_);
    std::size_t same = 0;
    Entry* oldest = nullptr;
    for (Entry& e : entries_) {
        if (e.client != client || !is_evictable(e))
            continue;
        ++same;
        if (!oldest || e.since < oldest->since)
            oldest = &e;
    }
    if (oldest && same >= max_evictable_per_client)
        evict_locked(*oldest);
    entries_.push_back(
        Entry{sock, std::move(client), ConnPhase::idle, std::chrono::steady_clock::now(), false});
    if (closing_)
        evict_locked(entries_.back());
    return std::prev(entries_.end());
}

void ConnectionRegistry::remove(Handle h) {
    std::lock_guard<std::mutex> lock(mu_);
    entries_.erase(h);
}

void ConnectionRegistry::set_phase(Handle h, ConnPhase p) {
    std::lock_guard<std::mutex> lock(mu_);
    h->phase = p;
    h->since = std::chrono::steady_clock::now();
}

bool ConnectionRegistry::evicted(Handle h) const {
    std::lock_guard<std::mutex> lock(mu_);
    return h->evicted;
}

void ConnectionRegistry::evict_locked(Entry& e) {
    e.evicted = true;
    ++evictions_;
    // Wakes the owner's poll with end-of-file; the owner closes the descriptor after remove().
    ::shutdown(e.sock, SHUT_RDWR);
}

bool ConnectionRegistry::evict_oldest() {
    std::lock_guard<std::mutex> lock(mu_);
    Entry* oldest = nullptr;
    for (Entry& e : entries_) {
        if (is_evictable(e) && (!oldest || e.since < oldest->since))
            oldest = &e;
    }
    if (!oldest)
        return false;
    evict_locked(*oldest);
    return true;
}

void ConnectionRegistry::close_all_evictable() {
    std::lock_guard<std::mutex> lock(mu_);
    closing_ = true;
    for (Entry& e : entries_) {
        if (is_evictable(e))
            evict_locked(e);
    }
}

std::size_t ConnectionRegistry::size() const {
    std::lock_guard<std::mutex> lock(mu_);
    return entries_.size();
}

std::size_t ConnectionRegistry::evictable() const {
    std::lock_guard<std::mutex> lock(mu_);
    std::size_t n = 0;
    for (const Entry& e : entries_)
        n += is_evictable(e);
    return n;
}

std::uint64_t ConnectionRegistry::evictions() const {
    std::lock_guard<std::mutex> lock(mu_);
    return evictions_;
}

// ---------------------------------------------------------------------------------------------

ConnectionThreads::ConnectionThreads(std::size_t max_threads, std::function<bool()> make_room,
                                     std::function<void()> on_shutdown)
    : max_threads_(max_threads == 0 ? 1 : max_threads),
      make_room_(std::move(make_room)),
      on_shutdown_(std::move(on_shutdown)) {}

ConnectionThreads::~ConnectionThreads() {
    shutdown();
}

void ConnectionThreads::enqueue(std::function<void()> fn) {
    bool full = false;
    {
        std::lock_guard<std::mutex> lock(mu_);
        jobs_.push_back(std::move(fn));
        if (idle_ >= jobs_.size()) {
            // a waiting thread takes it
        } else if (threads_.size() < max_threads_) {
            threads_.emplace_back([this] { run(); });
        } else {
            full = true;
        }
    }
    cv_.notify_one();
    // Outside our lock: eviction takes the registry's lock, and the evicted connection's thread
    // comes back here for the job.
    if (full && make_room_)
        make_room_();
}

void ConnectionThreads::shutdown() {
    {
        std::lock_guard<std::mutex> lock(mu_);
        if (stopping_ && threads_.empty())
            return;
        stopping_ = true;
    }
    if (on_shutdown_)
        on_shutdown_();
    cv_.notify_all();
    for (std::thread& t : threads_)
        t.join();
    threads_.clear();
}

void ConnectionThreads::run() {
    for (;;) {
        std::function<void()> job;
        {
            std::unique_lock<std::mutex> lock(mu_);
            ++idle_;
            cv_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
            --idle_;
            // Queued connections are still served when stopping: each job closes its socket.
            if (jobs_.empty())
                return;
            // Newest first: a queue forms only when every thread is taken (an attack or an
            // overload), and then the connection that has just arrived, for which a thread was
            // just freed by eviction, is the one to serve; older queued connections are the
            // likelier to be idle or abandoned (adaptive LIFO, as in Facebook's Wangle).
            job = std::move(jobs_.back());
            jobs_.pop_back();
        }
        job();
    }
}

}  // namespace raycastd::server
