#pragma once
// SceneCache: a small least-recently-used cache of the scenes that stateless calls
// (/v1/intersect, /v1/explain) build from inline documents, keyed by the SHA-256 of the
// canonical document. A grading script that posts the same scene with every question builds it
// once. Documents that name files (`uri`) are never cached: the files may change under them.

#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "engine/query/intersect.h"
#include "server/schema/json_read.h"

namespace raycastd::server {

class SceneCache {
  public:
    explicit SceneCache(std::size_t capacity) : capacity_(capacity) {}

    /// The cached scene for `doc`, or the result of `build()` (cached when cacheable).
    template <class Build>
    std::shared_ptr<const engine::QueryEngine> get_or_build(const Json& doc, Build&& build) {
        const std::string key = cache_key(doc);
        if (!key.empty()) {
            std::lock_guard<std::mutex> lock(mu_);
            auto it = map_.find(key);
            if (it != map_.end()) {
                order_.splice(order_.begin(), order_, it->second.second);
                ++hits_;
                return it->second.first;
            }
        }
        std::shared_ptr<const engine::QueryEngine> engine = build();
        if (!key.empty())
            insert(key, engine);
        return engine;
    }

    std::size_t hits() const {
        std::lock_guard<std::mutex> lock(mu_);
        return hits_;
    }

    /// "" when the document must not be cached (it refers to files).
    static std::string cache_key(const Json& doc);

  private:
    void insert(const std::string& key, std::shared_ptr<const engine::QueryEngine> engine);

    std::size_t capacity_;
    mutable std::mutex mu_;
    std::list<std::string> order_;  ///< most recently used first
    std::unordered_map<std::string, std::pair<std::shared_ptr<const engine::QueryEngine>,
                                              std::list<std::string>::iterator>>
        map_;
    std::size_t hits_ = 0;
};

}  // namespace raycastd::server
