#include "server/scene_registry.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "server/api_error.h"
#include "server/content_hash.h"
#include "server/durable_file.h"
#include "server/schema/json_read.h"
#include "server/schema/scene_doc.h"

namespace raycastd::server {

namespace fs = std::filesystem;

namespace {

Json info_json(const SceneInfo& i) {
    Json j = {{"id", i.id},
              {"objects", i.objects},
              {"triangles", i.triangles},
              {"spheres", i.spheres},
              {"build_ms", i.build_ms},
              {"features",
               {{"shadows", i.features.shadows},
                {"reflection", i.features.reflection},
                {"refraction", i.features.refraction},
                {"textures", i.features.textures}}},
              {"warnings", i.warnings},
              {"memory_bytes", i.memory_bytes},
              {"topology", topology_to_json(i.topology)},
              {"default_view", default_view_name(i.default_view)}};
    if (i.camera) {
        const engine::Camera& c = *i.camera;
        j["camera"] = {{"position", {c.position.x, c.position.y, c.position.z}},
                       {"look_at", {c.look_at.x, c.look_at.y, c.look_at.z}},
                       {"up", {c.up.x, c.up.y, c.up.z}},
                       {"fov_y_deg", c.fov_y_deg}};
    }
    if (i.bounds.empty()) {
        j["bounds"] = nullptr;
    } else {
        j["bounds"] = {{"min", {i.bounds.lo.x, i.bounds.lo.y, i.bounds.lo.z}},
                       {"max", {i.bounds.hi.x, i.bounds.hi.y, i.bounds.hi.z}}};
    }
    return j;
}

/// `view_known` tells whether the entry names its default view (scenes saved before the summary
/// had one do not). The camera and the view are extras the scene is usable without: one this
/// server would not read (a newer server's view name, a camera the document rules refuse) is
/// left out rather than dropping the scene, and the first build fills both in again
/// (make_resident).
SceneInfo info_from_json(const Json& j, bool& view_known) {
    SceneInfo i;
    i.id = j.at("id").get<std::string>();
    i.objects = j.at("objects").get<std::size_t>();
    i.triangles = j.at("triangles").get<std::size_t>();
    i.spheres = j.at("spheres").get<std::size_t>();
    i.build_ms = j.at("build_ms").get<double>();
    const Json& f = j.at("features");
    i.features = {f.at("shadows").get<bool>(), f.at("reflection").get<bool>(),
                  f.at("refraction").get<bool>(), f.at("textures").get<bool>()};
    i.warnings = j.at("warnings").get<std::vector<std::string>>();
    i.memory_bytes = j.at("memory_bytes").get<std::size_t>();
    if (const auto t = j.find("topology"); t != j.end())  // absent in scenes saved before it
        i.topology = topology_from_json(*t);
    view_known = false;
    if (const auto v = j.find("default_view"); v != j.end() && v->is_string()) {
        if (const auto view = default_view_from_name(v->get<std::string>())) {
            i.default_view = *view;
            view_known = true;
        }
    }
    if (const auto c = j.find("camera"); c != j.end() && !c->is_null()) {
        try {
            i.camera = parse_camera(*c, "/camera", ErrorCode::invalid_scene);
        } catch (const ApiError&) {
            i.camera.reset();
        }
    }
    if (!j.at("bounds").is_null()) {
        const auto lo = j.at("bounds").at("min").get<std::vector<double>>();
        const auto hi = j.at("bounds").at("max").get<std::vector<double>>();
        i.bounds.extend(engine::Vec3d{lo.at(0), lo.at(1), lo.at(2)});
        i.bounds.extend(engine::Vec3d{hi.at(0), hi.at(1), hi.at(2)});
    }
    return i;
}

}  // namespace

SceneInfo describe(const engine::QueryEngine& engine) {
    const engine::Scene& s = engine.scene();
    SceneInfo i;
    i.objects = s.objects.size();
    i.triangles = s.triangle_count();
    i.spheres = s.sphere_count();
    i.bounds = s.bounds();
    i.features = s.features();
    i.warnings = s.warnings;
    i.memory_bytes = engine.memory_bytes();
    i.topology = topology_entries(engine);
    i.camera = s.camera;
    i.default_view = s.default_view();
    return i;
}

namespace {

/// A saved copy's files are named after ids only: anything else is not looked up on disk.
bool is_scene_id(const std::string& id) {
    return !id.empty() && id.size() <= 128 && std::all_of(id.begin(), id.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
    });
}

/// The writer a tmp/ entry belongs to: the instance token in "<stem>.<token>.<n>" (every name
/// unique_tmp_name makes), or "" for a name of another shape.
std::string tmp_owner(const std::string& name) {
    const std::size_t last = name.rfind('.');
    if (last == std::string::npos || last == 0)
        return {};
    const std::size_t before = name.rfind('.', last - 1);
    if (before == std::string::npos)
        return {};
    return name.substr(before + 1, last - before - 1);
}

/// Whether the writer holding `lock` (locks/<token>.lock) is alive: it keeps an exclusive flock
/// on the file while it runs, which the kernel drops when it dies, kill -9 included (on NFS
/// too: Linux maps flock to the protocol's byte-range locks).
bool writer_alive(const fs::path& lock) {
    const int fd = ::open(lock.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return false;  // no lock file: its writer is gone (or predates locks)
    const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK;
    ::close(fd);
    return held;
}

/// What a saved copy (meta.json and body, and with `files` every file's copy) read from `dir`
/// holds, and what is wrong with it ("" when whole). The id is the hash of the request and of
/// every file (scene_id), so each byte is checked against it.
struct SavedCopy {
    std::map<std::string, std::string> names, file_sha;
    std::string content_type, request_key;
    std::optional<std::string> body;
    std::string damage;
    bool meta_missing = false;
};

/// What is wrong with the saved copy of file `path` of `c` ("" when it has its bytes, which go
/// to `bytes` if given).
std::string saved_file_damage(const fs::path& dir, const SavedCopy& c, const std::string& path,
                              std::string* bytes) {
    const auto name = c.names.find(path);
    const auto sha = c.file_sha.find(path);
    const std::optional<std::string> read =
        name == c.names.end() ? std::nullopt : read_file(dir / name->second);
    if (!read)
        return "its copy of \"" + path + "\" is missing";
    if (sha == c.file_sha.end() || sha256_hex(*read) != sha->second)
        return "its copy of \"" + path + "\" does not have the bytes it was read with";
    if (bytes)
        *bytes = *read;
    return {};
}

SavedCopy read_saved_copy(const fs::path& dir, const std::string& id, bool files) {
    SavedCopy c;
    const auto meta_text = read_file(dir / "meta.json");
    c.body = read_file(dir / "body");
    if (!meta_text) {
        c.meta_missing = true;
        c.damage = "its meta.json is missing";
        return c;
    }
    if (!c.body) {
        c.damage = "its body is missing";
        return c;
    }
    try {
        const std::optional<Json> meta = try_parse_json(*meta_text);
        if (!meta)
            throw std::runtime_error("not JSON");
        c.names = meta->at("files").get<std::map<std::string, std::string>>();
        c.file_sha = meta->at("file_sha").get<std::map<std::string, std::string>>();
        c.content_type = meta->at("content_type").get<std::string>();
        c.request_key = meta->at("request_key").get<std::string>();
    } catch (const std::exception& ex) {
        c.damage = std::string("its meta.json is unreadable: ") + ex.what();
        return c;
    }
    if (scene_request_key(c.content_type, *c.body) != c.request_key) {
        c.damage = "its body does not have the bytes it was registered with";
    } else if (scene_id(c.request_key, c.file_sha) != id) {
        c.damage = "its meta.json does not match the scene's id";
    } else if (files) {
        for (const auto& [path, sha] : c.file_sha) {
            c.damage = saved_file_damage(dir, c, path, nullptr);
            if (!c.damage.empty())
                break;
        }
    }
    return c;
}

}  // namespace

SceneRegistry::SceneRegistry(std::string data_dir, std::size_t memory_budget, Builder builder)
    : data_dir_(std::move(data_dir)), budget_(memory_budget), builder_(std::move(builder)) {
    std::random_device rd;
    char buf[17];
    std::snprintf(buf, sizeof buf, "%08x%08x", rd(), rd());
    instance_ = buf;
}

SceneRegistry::~SceneRegistry() {
    if (lock_fd_ >= 0)
        ::close(lock_fd_);  // releases the flock: this writer's leftovers may be removed
}

bool SceneRegistry::hold_writer_lock(std::string& error) {
    std::error_code ec;
    fs::create_directories(fs::path(data_dir_) / "locks", ec);
    const fs::path lock = fs::path(data_dir_) / "locks" / (instance_ + ".lock");
    // Another replica starting may take a lock file for a dead writer's between its creation
    // and its flock, and remove it: then it is made again (the path must name the locked file).
    for (int attempt = 0; attempt < 3; ++attempt) {
        // Read-only: a file open for writing would keep the data dir's filesystem from being
        // remounted read-only (and flock needs no write access).
        const int fd = ::open(lock.c_str(), O_RDONLY | O_CREAT | O_CLOEXEC, 0644);
        if (fd < 0)
            break;
        struct stat held {
        }, named{};
        if (::flock(fd, LOCK_EX | LOCK_NB) == 0 && ::fstat(fd, &held) == 0 &&
            ::stat(lock.c_str(), &named) == 0 && held.st_ino == named.st_ino &&
            held.st_dev == named.st_dev) {
            lock_fd_ = fd;
            return true;
        }
        ::close(fd);
    }
    // A data dir that refuses writes cannot hold a lock; it is served read-only (open() warns).
    if (errno == EROFS || errno == EACCES || errno == EPERM)
        return true;
    error = "cannot lock " + lock.string() + ": " + std::strerror(errno);
    return false;
}

std::string SceneRegistry::unique_tmp_name(const std::string& stem) const {
    static std::atomic<std::uint64_t> counter{0};
    return stem + "." + instance_ + "." + std::to_string(counter++);
}

bool SceneRegistry::open(std::string& error) {
    if (data_dir_.empty())
        return true;
    std::error_code ec;
    fs::create_directories(fs::path(data_dir_) / "scenes", ec);
    fs::create_directories(fs::path(data_dir_) / "tmp", ec);
    if (ec) {
        error = "cannot create data directory " + data_dir_ + ": " + ec.message();
        return false;
    }
    if (!hold_writer_lock(error))
        return false;
    // What is in tmp/ was never acknowledged. In a data dir shared by replicas some of it is
    // another replica's write in progress: an entry goes only when its writer's lock is free
    // (that process has ended).
    const fs::path tmp_dir = fs::path(data_dir_) / "tmp";
    const fs::path locks = fs::path(data_dir_) / "locks";
    std::map<std::string, bool> alive = {{instance_, true}};
    const auto owner_alive = [&](const std::string& owner) {
        auto it = alive.find(owner);
        if (it == alive.end())
            it = alive.emplace(owner, writer_alive(locks / (owner + ".lock"))).first;
        return it->second;
    };
    for (const auto& d : fs::directory_iterator(tmp_dir, ec)) {
        std::error_code rm_ec;
        if (!owner_alive(tmp_owner(d.path().filename().string())))
            fs::remove_all(d.path(), rm_ec);
    }
    // Dead writers' locks go after their entries, so that a crash here leaves them dead.
    for (const auto& d : fs::directory_iterator(locks, ec)) {
        std::error_code rm_ec;
        if (d.path().extension() == ".lock" && !owner_alive(d.path().stem().string()))
            fs::remove(d.path(), rm_ec);
    }
    // A data dir that refuses writes (read-only mount, full disk) still serves what it holds;
    // registering and deleting will answer 507. Said once, loudly, at start-up.
    IoError probe_error;
    const fs::path probe = fs::path(data_dir_) / "tmp" / unique_tmp_name(".probe");
    if (!write_synced(probe, "probe", probe_error)) {
        std::fprintf(stderr,
                     "raycastd: WARNING: the data directory %s refuses writes (%s): its scenes "
                     "are served, but registering and deleting scenes will answer 507 "
                     "insufficient_storage\n",
                     data_dir_.c_str(), probe_error.message.c_str());
    }
    fs::remove(probe, ec);
    std::vector<Entry> saved;
    for (const auto& d : fs::directory_iterator(fs::path(data_dir_) / "scenes", ec)) {
        if (auto e = read_saved(d.path().filename().string()))
            saved.push_back(std::move(*e));
    }
    std::lock_guard<std::mutex> lock(mu_);
    for (Entry& e : saved) {
        e.lru = lru_.end();
        const std::string id = e.info.id;
        by_request_key_.emplace(e.request_key, id);
        entries_.emplace(id, std::move(e));
    }
    return true;
}

std::optional<SceneRegistry::Entry> SceneRegistry::read_saved(const std::string& id) const {
    if (data_dir_.empty() || !is_scene_id(id))
        return std::nullopt;
    const fs::path dir = fs::path(data_dir_) / "scenes" / id;
    auto meta = read_file(dir / "meta.json");
    if (!meta)
        return std::nullopt;
    try {
        const Json m = Json::parse(*meta);
        Entry e;
        bool view_known = false;
        e.info = info_from_json(m.at("info"), view_known);
        if (!view_known) {
            // Saved before the summary named it: the view the scene's objects give it
            // (engine::Scene::default_view), told from its source without building it: a model
            // file, or a document with a mesh object, is seen from +z.
            const std::string type = m.at("content_type").get<std::string>();
            bool model = type != "application/json";
            if (!model) {
                const auto body = read_file(dir / "body");
                const std::optional<Json> doc = body ? try_parse_json(*body) : std::nullopt;
                const Json* objects = doc && doc->is_object() ? member(*doc, "objects") : nullptr;
                model = objects && objects->is_array() &&
                        std::any_of(objects->begin(), objects->end(), [](const Json& o) {
                            const Json* t = o.is_object() ? member(o, "type") : nullptr;
                            return t && *t == "mesh";
                        });
            }
            e.info.default_view =
                model ? engine::DefaultView::from_plus_z : engine::DefaultView::from_minus_z;
        }
        e.request_key = m.at("request_key").get<std::string>();
        e.file_sha = m.at("file_sha").get<std::map<std::string, std::string>>();
        if (e.info.id != id)
            throw std::runtime_error("its meta.json names " + e.info.id);
        return e;
    } catch (const std::exception& ex) {
        std::fprintf(stderr, "raycastd: skipping unreadable saved scene %s: %s\n", dir.c_str(),
                     ex.what());
        return std::nullopt;
    }
}

bool SceneRegistry::adopt_saved(const std::string& id) {
    auto e = read_saved(id);
    if (!e)
        return false;
    std::lock_guard<std::mutex> lock(mu_);
    e->lru = lru_.end();  // lru_ is guarded by mu_: the iterator is taken under it
    auto [it, inserted] = entries_.emplace(id, std::move(*e));
    if (inserted)
        by_request_key_.emplace(it->second.request_key, id);
    return true;
}

SceneRegistry::Added SceneRegistry::add(const SceneSource& source, const FileSource& root_files) {
    const std::string request_key = scene_request_key(source.content_type, source.body);

    // Same request as a registered scene, and every file it read still has the same bytes:
    // the same scene, without building anything.
    std::vector<std::pair<std::string, std::map<std::string, std::string>>> candidates;
    {
        std::lock_guard<std::mutex> lock(mu_);
        auto range = by_request_key_.equal_range(request_key);
        for (auto it = range.first; it != range.second; ++it) {
            candidates.emplace_back(it->second, entries_.at(it->second).file_sha);
        }
    }
    for (const auto& [id, files] : candidates) {
        bool same = true;
        for (const auto& [path, sha] : files) {
            auto bytes = root_files(path);
            if (!bytes.ok() || sha256_hex(*bytes) != sha) {
                same = false;
                break;
            }
        }
        if (!same)
            continue;
        std::lock_guard<std::mutex> lock(mu_);
        auto it = entries_.find(id);
        if (it != entries_.end())
            return {it->second.info, false};
    }

    // Build, recording every file read; the id covers the request and those files.
    std::map<std::string, std::string> read_files;
    FileSource recording = [&](const std::string& path) -> engine::Result<std::string> {
        auto bytes = root_files(path);
        if (bytes.ok())
            read_files[path] = *bytes;
        return bytes;
    };
    const auto t0 = std::chrono::steady_clock::now();
    std::shared_ptr<const engine::QueryEngine> engine = builder_(source, recording);
    const double build_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

    Entry e;
    e.request_key = request_key;
    for (const auto& [path, bytes] : read_files)
        e.file_sha[path] = sha256_hex(bytes);
    e.info = describe(*engine);
    e.info.id = scene_id(request_key, e.file_sha);
    e.info.build_ms = build_ms;
    const std::string id = e.info.id;
    {
        std::lock_guard<std::mutex> lock(mu_);
        e.lru = lru_.end();
        auto it = entries_.find(id);
        if (it != entries_.end())
            return {it->second.info, false};
    }
    IoError error;
    Saved saved = Saved::now;
    if (!data_dir_.empty()) {
        saved = persist(id, source, read_files, e, error);
        if (saved == Saved::failed) {
            if (error.storage_refused()) {
                throw ApiError(
                    ErrorCode::insufficient_storage,
                    "cannot save the scene, so nothing was registered: " + error.message);
            }
            throw ApiError(ErrorCode::internal, "cannot save the scene: " + error.message);
        }
    }
    // Created: with a data dir, by the one writer whose rename published the copy (of all the
    // threads and replicas posting the same content at once); without, by the first insert.
    const bool published = data_dir_.empty() || saved == Saved::now;
    std::lock_guard<std::mutex> lock(mu_);
    auto [it, inserted] = entries_.emplace(id, std::move(e));
    if (!inserted)
        return {it->second.info, !data_dir_.empty() && published};  // a concurrent post
    by_request_key_.emplace(request_key, id);
    make_resident(it->second, std::move(engine));
    evict_over_budget(id);
    return {it->second.info, published};
}

SceneRegistry::Saved SceneRegistry::persist(const std::string& id, const SceneSource& source,
                                            const std::map<std::string, std::string>& files,
                                            const Entry& e, IoError& error) const {
    const fs::path scenes = fs::path(data_dir_) / "scenes";
    const fs::path final_dir = scenes / id;
    std::error_code ec;
    if (fs::exists(final_dir / "meta.json", ec)) {
        const std::string damage = read_saved_copy(final_dir, id, /*files=*/true).damage;
        if (damage.empty())
            return Saved::already;
        // A damaged copy (rebuild says how it shows) is moved aside and replaced by this one.
        // Two writers may both find it damaged: the second rename finds it gone, which is fine.
        std::fprintf(stderr, "raycastd: replacing the damaged saved copy %s (%s)\n",
                     final_dir.c_str(), damage.c_str());
        const fs::path aside = fs::path(data_dir_) / "tmp" / unique_tmp_name(id + ".damaged");
        fs::rename(final_dir, aside, ec);
        fs::remove_all(aside, ec);
    }
    const fs::path tmp = fs::path(data_dir_) / "tmp" / unique_tmp_name(id);
    fs::create_directories(tmp, ec);
    if (ec) {
        error.code = ec.value();
        error.message = "cannot create " + tmp.string() + ": " + ec.message();
        return Saved::failed;
    }
    Json file_names = Json::object();
    std::size_t k = 0;
    bool ok = write_synced(tmp / "body", source.body, error);
    for (const auto& [path, bytes] : files) {
        const std::string name = "file" + std::to_string(k++);
        file_names[path] = name;
        ok = ok && write_synced(tmp / name, bytes, error);
    }
    const Json meta = {{"format", 1},
                       {"content_type", source.content_type},
                       {"request_key", e.request_key},
                       {"file_sha", e.file_sha},
                       {"files", file_names},
                       {"info", info_json(e.info)}};
    // meta.json is written last: a directory is a saved copy once it holds one, and only a
    // rename of a complete temp dir ever creates scenes/<id>.
    ok = ok && write_synced(tmp / "meta.json",
                            meta.dump(1, ' ', false, Json::error_handler_t::replace), error);
    ok = ok && sync_dir(tmp, error);
    if (!ok) {
        fs::remove_all(tmp, ec);
        return Saved::failed;
    }
    if (rename_synced(tmp, final_dir, error))
        return Saved::now;
    fs::remove_all(tmp, ec);
    // rename(2) onto a directory that is not empty fails (ENOTEMPTY, or EEXIST): another writer
    // published the same id first. Its copy has the same bytes (the id is their hash), and a
    // whole copy is never replaced, so that a replica reading it meanwhile reads whole files
    // (a damaged one is moved aside above: a replica rebuilding from it at that moment finds
    // it gone and answers 404 for that request).
    if (fs::exists(final_dir / "meta.json", ec)) {
        error = {};
        return Saved::already;
    }
    return Saved::failed;
}

std::shared_ptr<const engine::QueryEngine> SceneRegistry::rebuild(const std::string& id) {
    const fs::path dir = fs::path(data_dir_) / "scenes" / id;
    // A copy damaged on disk (a file removed or changed by hand, a bad sector) is refused rather
    // than built: built, it would answer as a different scene under this id. The scene stays
    // registered; DELETE removes the copy, and registering the scene again saves a new one (so
    // does registering it again where the copy's meta.json is unreadable, which makes the scene
    // unknown: persist replaces a damaged copy).
    const auto damaged = [&](const std::string& what) {
        std::fprintf(stderr, "raycastd: the saved copy of %s is damaged: %s\n", dir.c_str(),
                     what.c_str());
        return ApiError(ErrorCode::internal, "the saved copy of scene " + id +
                                                 " in the data dir is damaged (" + what +
                                                 "): DELETE the scene and register it again");
    };
    const SavedCopy copy = read_saved_copy(dir, id, /*files=*/false);
    if (copy.meta_missing || !copy.body) {
        std::error_code ec;
        if (!fs::exists(dir, ec))
            return nullptr;  // deleted through another replica sharing the data dir
    }
    if (!copy.damage.empty())
        throw damaged(copy.damage);
    // Replay exactly the bytes the scene was built from, not today's files under the root. A
    // damaged file is an error Status to the loader (which may turn it into its own error or
    // carry on without the file) and the rebuild's answer after it.
    std::string damage;
    FileSource saved = [&](const std::string& path) -> engine::Result<std::string> {
        if (copy.names.count(path) == 0 || copy.file_sha.count(path) == 0) {
            return engine::Status::error(engine::Code::invalid_scene,
                                         "\"" + path + "\" was not part of the saved scene");
        }
        std::string bytes;
        damage = saved_file_damage(dir, copy, path, &bytes);
        if (!damage.empty())
            return engine::Status::error(engine::Code::internal, damage);
        return bytes;
    };
    std::shared_ptr<const engine::QueryEngine> engine;
    try {
        engine = builder_(SceneSource{copy.content_type, *copy.body}, saved);
    } catch (...) {
        if (!damage.empty())
            throw damaged(damage);
        throw;
    }
    if (!damage.empty())
        throw damaged(damage);
    return engine;
}

std::shared_ptr<const engine::QueryEngine> SceneRegistry::get(const std::string& id) {
    bool known = false;
    {
        std::lock_guard<std::mutex> lock(mu_);
        auto it = entries_.find(id);
        if (it != entries_.end()) {
            if (it->second.engine) {
                touch(it->second);
                refresh_bytes(it->second);
                return it->second.engine;
            }
            known = true;
        }
    }
    // Unknown here: perhaps registered by another replica sharing the data dir.
    if (!known && !adopt_saved(id))
        return nullptr;
    // Rebuilt outside the lock: other scenes stay available meanwhile. Two threads may rebuild
    // the same scene at once; the first to finish is kept.
    auto engine = rebuild(id);
    std::lock_guard<std::mutex> lock(mu_);
    auto it = entries_.find(id);
    if (!engine) {
        // Its saved copy was deleted through another replica: deleted here too.
        if (it != entries_.end() && !it->second.engine)
            forget(it);
        return nullptr;
    }
    if (it == entries_.end())
        return engine;  // deleted meanwhile: serve this request only
    if (!it->second.engine)
        make_resident(it->second, engine);
    touch(it->second);
    evict_over_budget(id);
    return it->second.engine;
}

void SceneRegistry::make_resident(Entry& e, std::shared_ptr<const engine::QueryEngine> engine) {
    e.engine = std::move(engine);
    lru_.push_front(e.info.id);
    e.lru = lru_.begin();
    e.info.memory_bytes = e.engine->memory_bytes();  // a rebuilt engine has no lazy BVHs yet
    resident_bytes_ += e.info.memory_bytes;
    // The built scene says what its camera and view are; an entry saved before the summary had
    // them (or by a server that framed differently) is told them from now on.
    e.info.camera = e.engine->scene().camera;
    e.info.default_view = e.engine->scene().default_view();
}

void SceneRegistry::refresh_bytes(Entry& e) {
    // The first exact or fast query builds another BVH (engine/accel/embree_accel.h): count it
    // against the budget from the next request on, and show it in the scene's info.
    const std::size_t now = e.engine->memory_bytes();
    if (now == e.info.memory_bytes)
        return;
    resident_bytes_ = resident_bytes_ - e.info.memory_bytes + now;
    e.info.memory_bytes = now;
    evict_over_budget(e.info.id);
}

void SceneRegistry::touch(Entry& e) {
    if (e.lru != lru_.end())
        lru_.splice(lru_.begin(), lru_, e.lru);
}

void SceneRegistry::evict_over_budget(const std::string& keep) {
    if (data_dir_.empty())
        return;  // nothing to reload from
    while (resident_bytes_ > budget_ && !lru_.empty()) {
        const std::string victim = lru_.back();
        if (victim == keep)
            break;
        Entry& e = entries_.at(victim);
        lru_.pop_back();
        e.lru = lru_.end();
        e.engine.reset();  // requests still holding it finish with their own reference
        resident_bytes_ -= e.info.memory_bytes;
    }
}

std::optional<SceneInfo> SceneRegistry::info(const std::string& id) {
    {
        std::lock_guard<std::mutex> lock(mu_);
        auto it = entries_.find(id);
        if (it != entries_.end())
            return it->second.info;
    }
    if (!adopt_saved(id))
        return std::nullopt;
    std::lock_guard<std::mutex> lock(mu_);
    auto it = entries_.find(id);
    if (it == entries_.end())
        return std::nullopt;
    return it->second.info;
}

std::vector<SceneInfo> SceneRegistry::list() {
    // Scenes other replicas saved in a shared data dir since this one opened it are listed too.
    if (!data_dir_.empty()) {
        std::error_code ec;
        for (const auto& d : fs::directory_iterator(fs::path(data_dir_) / "scenes", ec)) {
            const std::string id = d.path().filename().string();
            bool known = false;
            {
                std::lock_guard<std::mutex> lock(mu_);
                known = entries_.count(id) > 0;
            }
            if (!known)
                adopt_saved(id);
        }
    }
    std::lock_guard<std::mutex> lock(mu_);
    std::vector<SceneInfo> out;
    for (const auto& [id, e] : entries_)
        out.push_back(e.info);
    return out;
}

void SceneRegistry::forget(std::map<std::string, Entry>::iterator it) {
    Entry& e = it->second;
    if (e.engine)
        resident_bytes_ -= e.info.memory_bytes;
    if (e.lru != lru_.end())
        lru_.erase(e.lru);
    auto range = by_request_key_.equal_range(e.request_key);
    for (auto k = range.first; k != range.second; ++k) {
        if (k->second == it->first) {
            by_request_key_.erase(k);
            break;
        }
    }
    entries_.erase(it);
}

bool SceneRegistry::remove(const std::string& id) {
    const fs::path deleted = fs::path(data_dir_) / "tmp" / unique_tmp_name(id + ".deleted");
    if (!info(id))  // a scene saved by another replica can be deleted through this one
        return false;
    {
        std::lock_guard<std::mutex> lock(mu_);
        auto it = entries_.find(id);
        if (it == entries_.end())
            return false;
        // The saved copy goes first (renamed aside, so that a crash mid-delete never leaves a
        // half-deleted scene to reload), and only then the entry: a data dir that refuses the
        // rename (read-only) leaves the scene registered, on disk and in memory, and says so.
        // The rename is under the lock so that a concurrent add of the same content cannot
        // save its copy between the two steps.
        if (!data_dir_.empty()) {
            IoError error;
            const fs::path saved = fs::path(data_dir_) / "scenes" / id;
            std::error_code ec;
            if (fs::exists(saved, ec) && !rename_synced(saved, deleted, error)) {
                throw ApiError(
                    error.storage_refused() ? ErrorCode::insufficient_storage : ErrorCode::internal,
                    "cannot delete the saved copy of " + id +
                        ", so the scene stays registered: " + error.message);
            }
        }
        forget(it);
    }
    if (!data_dir_.empty()) {
        std::error_code ec;
        fs::remove_all(deleted, ec);  // what stays is removed by a later open()
    }
    return true;
}

std::size_t SceneRegistry::size() const {
    std::lock_guard<std::mutex> lock(mu_);
    return entries_.size();
}

std::size_t SceneRegistry::resident() const {
    std::lock_guard<std::mutex> lock(mu_);
    return lru_.size();
}

std::size_t SceneRegistry::resident_bytes() const {
    std::lock_guard<std::mutex> lock(mu_);
    return resident_bytes_;
}

}  // namespace raycastd::server
