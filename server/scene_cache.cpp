#include "server/scene_cache.h"

#include "server/content_hash.h"

namespace raycastd::server {

namespace {

bool names_files(const Json& doc) {
    const Json* objects = member(doc, "objects");
    if (!objects || !objects->is_array())
        return false;
    for (const Json& o : *objects) {
        if (o.is_object() && o.contains("uri"))
            return true;
    }
    return false;
}

}  // namespace

std::string SceneCache::cache_key(const Json& doc) {
    if (!doc.is_object() || names_files(doc))
        return {};
    return sha256_hex(canonical_json(doc));
}

void SceneCache::insert(const std::string& key, std::shared_ptr<const engine::QueryEngine> engine) {
    std::lock_guard<std::mutex> lock(mu_);
    if (capacity_ == 0 || map_.count(key))
        return;
    order_.push_front(key);
    map_.emplace(key, std::make_pair(std::move(engine), order_.begin()));
    while (map_.size() > capacity_) {
        map_.erase(order_.back());
        order_.pop_back();
    }
}

}  // namespace raycastd::server
