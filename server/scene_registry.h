#pragma once
// SceneRegistry: the only shared mutable state of the server. Content hash → prepared scene.
//
//  * Ids are content hashes of the canonical request (a scene document re-serialised with sorted
//    keys, or the model bytes) and of every file the scene read while loading
//    (server/content_hash.h), so posting the same thing twice gives the same id and, the second
//    time, does no build at all.
//  * A scene is built completely before it is inserted (all-or-nothing): a failed build leaves
//    the registry as it was, and no request ever sees a half-built scene.
//  * With a data directory, every acknowledged scene is first written to disk (a temp dir,
//    published by one rename; server/durable_file.h), together with copies of the files it
//    read, so a restarted server (even after kill -9) answers for it, from exactly the bytes it
//    was built from.
//  * A memory budget evicts the least recently used scenes from memory; they are rebuilt from
//    their saved copies on next use. Without a data directory nothing is evicted.
//  * Replicas may share one data directory (docs/deploy.md): an id this registry does not know
//    is looked up there before it is called unknown, so any replica serves any scene another
//    registered. Concurrent writers of one id (two replicas, or two threads) each write a
//    temp dir of their own (a name unique across hosts and containers, where pids repeat) and
//    publish it by rename(2), and holds a lock (locks/<token>.lock) while it lives, so that a
//    replica starting removes only the leftovers of writers that have died. The loser of a
//    race finds the winner's complete copy in place, which has the same bytes (the id is
//    their hash), and keeps it. Nothing ever removes a published copy except DELETE.

#include <chrono>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "engine/query/intersect.h"
#include "server/durable_file.h"
#include "server/model_source.h"
#include "server/schema/topology_doc.h"

namespace raycastd::server {

/// What the API reports about a registered scene.
struct SceneInfo {
    std::string id;
    std::size_t objects = 0, triangles = 0, spheres = 0;
    engine::Bounds3 bounds;
    double build_ms = 0;
    engine::Features features;
    std::vector<std::string> warnings;
    std::size_t memory_bytes = 0;          ///< estimate of the prepared scene's footprint
    std::vector<TopologyEntry> topology;   ///< one per mesh object (schema/topology_doc.h)
    std::optional<engine::Camera> camera;  ///< the scene's own (its document's, else its file's)
    /// The side of the bounds a render without a camera sees the scene from.
    engine::DefaultView default_view = engine::DefaultView::from_minus_z;
};

class SceneRegistry {
  public:
    /// Builds a scene from its source, reading the files it refers to through `files`.
    /// Throws ApiError for bad input.
    using Builder = std::function<std::shared_ptr<const engine::QueryEngine>(
        const SceneSource& source, const FileSource& files)>;

    SceneRegistry(std::string data_dir, std::size_t memory_budget, Builder builder);
    ~SceneRegistry();
    SceneRegistry(const SceneRegistry&) = delete;
    SceneRegistry& operator=(const SceneRegistry&) = delete;

    /// Loads the index of the scenes saved in the data directory (their engines are built on
    /// first use). False with `error` when the directory cannot be used.
    bool open(std::string& error);

    struct Added {
        SceneInfo info;
        bool created = false;  ///< false: the same content was already registered
    };
    /// Registers a scene; `root_files` reads files under the scene root. Throws ApiError
    /// (insufficient_storage when the data dir refuses the saved copy: nothing is registered).
    Added add(const SceneSource& source, const FileSource& root_files);

    /// The prepared scene, rebuilt from disk if it was evicted or was saved by another replica
    /// sharing the data dir; nullptr for an unknown id (or one whose saved copy another replica
    /// has deleted since).
    std::shared_ptr<const engine::QueryEngine> get(const std::string& id);
    /// The scene's summary (looked up in the data dir too); nullopt for an unknown id.
    std::optional<SceneInfo> info(const std::string& id);
    /// Every scene known here and saved in the data dir, by id.
    std::vector<SceneInfo> list();
    /// Deletes the scene's saved copy, then forgets the scene; false for an unknown id. Throws
    /// ApiError insufficient_storage, with the scene still registered, when the data dir
    /// refuses the deletion (read-only).
    bool remove(const std::string& id);

    std::size_t size() const;
    std::size_t resident() const;
    std::size_t resident_bytes() const;

  private:
    struct Entry {
        SceneInfo info;
        std::string request_key;                            ///< hash of the canonical request alone
        std::map<std::string, std::string> file_sha;        ///< files it read → their SHA-256
        std::shared_ptr<const engine::QueryEngine> engine;  ///< null while evicted
        std::list<std::string>::iterator lru;
    };

    /// Reads the saved copy's index entry (meta.json) into an Entry; nullopt when there is
    /// none (or it is unreadable: said on stderr).
    std::optional<Entry> read_saved(const std::string& id) const;
    /// Makes a scene saved in the data dir (by another replica) known here; false when the dir
    /// has no such scene.
    bool adopt_saved(const std::string& id);
    /// nullptr when the saved copy is gone (deleted through another replica).
    std::shared_ptr<const engine::QueryEngine> rebuild(const std::string& id);
    /// Drops an entry and its LRU place, request key and bytes (with mu_ held).
    void forget(std::map<std::string, Entry>::iterator it);
    void make_resident(Entry& e, std::shared_ptr<const engine::QueryEngine> engine);
    void touch(Entry& e);
    /// Takes e's memory_bytes anew (it grows when a query builds a lazy BVH).
    void refresh_bytes(Entry& e);
    void evict_over_budget(const std::string& keep);
    enum class Saved { now, already, failed };
    /// Saves the scene's copy: `already` when the data dir holds it (an earlier run, another
    /// replica, or a concurrent writer that published first).
    Saved persist(const std::string& id, const SceneSource& source,
                  const std::map<std::string, std::string>& files, const Entry& e,
                  IoError& error) const;
    /// Takes locks/<instance>.lock (an exclusive flock held while this registry lives), by which
    /// other replicas opening the data dir tell this one's writes in progress from a dead
    /// writer's leftovers. False with `error` when the lock cannot be taken in a writable dir.
    bool hold_writer_lock(std::string& error);
    /// A name in tmp/ no other writer uses, on any host sharing the data dir.
    std::string unique_tmp_name(const std::string& stem) const;

    std::string data_dir_;
    std::string instance_;  ///< random, per registry: tmp names of replicas never collide
    int lock_fd_ = -1;      ///< holds the flock of locks/<instance_>.lock
    std::size_t budget_;
    Builder builder_;
    mutable std::mutex mu_;
    std::map<std::string, Entry> entries_;
    std::multimap<std::string, std::string> by_request_key_;
    std::list<std::string> lru_;  ///< resident ids, most recently used first
    std::size_t resident_bytes_ = 0;
};

/// A summary of a prepared scene (counts, bounds, features, memory estimate).
SceneInfo describe(const engine::QueryEngine& engine);

}  // namespace raycastd::server
