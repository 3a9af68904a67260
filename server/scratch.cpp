#include "server/scratch.h"

namespace raycastd::server {

namespace {

/// Sets kept between requests: the work requests that run at once on 2 cores, and then some.
constexpr std::size_t kRetained = 4;

struct Pool {
    std::mutex mutex;
    std::vector<std::unique_ptr<Scratch>> free;
};

Pool& pool() {
    static Pool* p = new Pool;  // never destroyed: responses may release during shutdown
    return *p;
}

}  // namespace

std::shared_ptr<Scratch> acquire_scratch() {
    std::unique_ptr<Scratch> s;
    {
        std::lock_guard<std::mutex> lock(pool().mutex);
        if (!pool().free.empty()) {
            s = std::move(pool().free.back());
            pool().free.pop_back();
        }
    }
    if (!s)
        s = std::make_unique<Scratch>();
    return std::shared_ptr<Scratch>(s.release(), [](Scratch* p) {
        std::unique_ptr<Scratch> owned(p);
        if (!owned->discard) {
            std::lock_guard<std::mutex> lock(pool().mutex);
            if (pool().free.size() < kRetained)
                pool().free.push_back(std::move(owned));
        }
        // A set the pool does not keep is freed here, outside the lock.
    });
}

}  // namespace raycastd::server
