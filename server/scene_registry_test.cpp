#include "server/scene_registry.h"

#include <atomic>
#include <filesystem>
#include <fstream>
#include <thread>

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include "engine/query/intersect.h"
#include "server/model_source.h"

namespace raycastd::server {
namespace {

namespace fs = std::filesystem;

const char* kSpheres = R"({"objects":[{"type":"sphere","center":[0,0,10],"radius":2},
                                       {"type":"sphere","center":[0,1,9],"radius":2}]})";

struct TempDir {
    fs::path path = fs::temp_directory_path() /
                    ("raycastd_reg_" + std::to_string(::getpid()) + "_" +
                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    TempDir() { fs::remove_all(path); }
    ~TempDir() { fs::remove_all(path); }
};

/// A registry whose builder is the server's own (ModelSource::build_scene), counting builds.
struct Fixture {
    explicit Fixture(const std::string& data_dir, std::size_t budget = 1u << 30)
        : models(Limits{}, "."),
          registry(data_dir, budget, [this](const SceneSource& s, const FileSource& f) {
              ++builds;
              return models.build_scene(s, f);
          }) {
        std::string error;
        EXPECT_TRUE(registry.open(error)) << error;
    }
    ModelSource models;
    std::atomic<int> builds{0};
    SceneRegistry registry;
};

FileSource no_files() {
    return [](const std::string& p) -> engine::Result<std::string> {
        return engine::Status::error(engine::Code::invalid_scene, "no file " + p);
    };
}

TEST(SceneRegistry, SameContentSameIdNoSecondBuild) {
    Fixture f("");
    auto a = f.registry.add({"application/json", kSpheres}, no_files());
    EXPECT_TRUE(a.created);
    EXPECT_EQ(a.info.id.rfind("sc_", 0), 0u);
    EXPECT_EQ(a.info.spheres, 2u);
    // The same document with other whitespace and key order is the same scene.
    auto b = f.registry.add({"application/json",
                             R"({ "objects" : [ {"radius":2, "type":"sphere","center":[0,0,10]},
                            {"type":"sphere","center":[0,1,9],"radius":2.0} ] })"},
                            no_files());
    EXPECT_FALSE(b.created);
    EXPECT_EQ(b.info.id, a.info.id);
    EXPECT_EQ(f.builds.load(), 1);
    EXPECT_TRUE(f.registry.get(a.info.id));
    EXPECT_FALSE(f.registry.get("sc_nope"));
}

TEST(SceneRegistry, FailedBuildLeavesRegistryUntouched) {
    Fixture f("");
    auto a = f.registry.add({"application/json", kSpheres}, no_files());
    EXPECT_THROW(
        f.registry.add({"application/json", R"({"objects":[{"type":"sphere"}]})"}, no_files()),
        ApiError);
    EXPECT_THROW(f.registry.add({"application/json", "{oops"}, no_files()), ApiError);
    EXPECT_EQ(f.registry.size(), 1u);
    EXPECT_TRUE(f.registry.get(a.info.id));
}

TEST(SceneRegistry, PersistsAndReloadsAfterRestart) {
    TempDir dir;
    std::string id;
    {
        Fixture f(dir.path.string());
        id = f.registry.add({"application/json", kSpheres}, no_files()).info.id;
    }
    Fixture g(dir.path.string());
    EXPECT_EQ(g.registry.size(), 1u);
    auto info = g.registry.info(id);
    ASSERT_TRUE(info);
    EXPECT_EQ(info->spheres, 2u);
    EXPECT_EQ(g.builds.load(), 0);  // lazily rebuilt on first use
    auto engine = g.registry.get(id);
    ASSERT_TRUE(engine);
    EXPECT_EQ(g.builds.load(), 1);
    EXPECT_EQ(engine->scene().objects.size(), 2u);
    // Leftovers of a writer that died are ignored and cleaned up; the temp files of a writer
    // still running (another replica on a shared data dir, holding its lock) are left alone.
    const fs::path dead_write = dir.path / "tmp" / "sc_half.123.0";
    const fs::path live_write = dir.path / "tmp" / "sc_live.feedface.0";
    const fs::path live_lock = dir.path / "locks" / "feedface.lock";
    fs::create_directories(dead_write);
    fs::create_directories(live_write);
    const int fd = ::open(live_lock.c_str(), O_RDWR | O_CREAT, 0644);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(::flock(fd, LOCK_EX), 0);
    {
        Fixture h(dir.path.string());
        EXPECT_EQ(h.registry.size(), 1u);
        EXPECT_FALSE(fs::exists(dead_write));
        EXPECT_TRUE(fs::exists(live_write));
        EXPECT_TRUE(fs::exists(live_lock));
    }
    ::close(fd);  // that writer ends (as kill -9 would end it): its leftovers go next time
    Fixture k(dir.path.string());
    EXPECT_FALSE(fs::exists(live_write));
    EXPECT_FALSE(fs::exists(live_lock));
}

TEST(SceneRegistry, SummaryKeepsTheCameraAndDefaultViewOfScenesSavedBeforeThem) {
    // Scenes saved before the summary carried `camera` and `default_view` have neither in their
    // meta.json: they come back with no camera and the view their objects give them, told from
    // their saved source without building it (a model file, or a document with a mesh object,
    // +z; spheres and triangles, −z), which is what a rebuild gives them.
    TempDir dir;
    const std::string off = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    const std::string doc_with_mesh =
        R"({"objects":[{"type":"sphere","center":[0,0,10],"radius":2},{"type":"mesh",
            "format":"off","data_base64":"T0ZGCjMgMSAwCjAgMCAwCjEgMCAwCjAgMSAwCjMgMCAxIDIK"}]})";
    std::vector<std::pair<std::string, engine::DefaultView>> saved;
    {
        Fixture f(dir.path.string());
        for (const SceneSource& src :
             {SceneSource{"application/json", kSpheres}, SceneSource{"model/off", off},
              SceneSource{"application/json", doc_with_mesh}}) {
            const SceneInfo info = f.registry.add(src, no_files()).info;
            EXPECT_FALSE(info.camera);
            saved.emplace_back(info.id, info.default_view);
        }
    }
    ASSERT_EQ(saved.size(), 3u);
    EXPECT_EQ(saved[0].second, engine::DefaultView::from_minus_z);
    EXPECT_EQ(saved[1].second, engine::DefaultView::from_plus_z);
    EXPECT_EQ(saved[2].second, engine::DefaultView::from_plus_z);
    for (const auto& [id, view] : saved) {
        const fs::path meta = dir.path / "scenes" / id / "meta.json";
        std::ifstream in(meta);
        Json m = Json::parse(in);
        ASSERT_TRUE(m.at("info").contains("default_view"));
        m["info"].erase("default_view");
        m["info"].erase("camera");
        std::ofstream(meta) << m.dump();
    }
    Fixture g(dir.path.string());
    for (const auto& [id, view] : saved)
        EXPECT_EQ(g.registry.info(id)->default_view, view) << id;
    EXPECT_EQ(g.builds.load(), 0);
    // A glTF with a camera (at (0.5, 0.5, 4), looking along −z at its triangle): the summary
    // gives the camera, aimed at the triangle's centre. Saved with the camera left out, a view
    // name this server does not know and, for a second scene, a camera it would refuse, both
    // still load (the extras are left out, the view told from the source), and their first
    // build gives them the camera again.
    const std::string gltf =
        R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":36,"uri":"data:application/)"
        R"(octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],)"
        R"("bufferViews":[{"buffer":0,"byteLength":36}],"accessors":[{"bufferView":0,)"
        R"("componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],)"
        R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"cameras":[{"type":)"
        R"("perspective","perspective":{"yfov":0.5,"znear":0.1}}],"nodes":[{"mesh":0},)"
        R"({"translation":[0.5,0.5,4],"camera":0}],"scenes":[{"nodes":[0,1]}],"scene":0})";
    const SceneInfo with = g.registry.add({"model/gltf+json", gltf}, no_files()).info;
    ASSERT_TRUE(with.camera);
    EXPECT_EQ(with.camera->position, (engine::Vec3d{0.5, 0.5, 4}));
    EXPECT_EQ(with.camera->look_at, (engine::Vec3d{0.5, 0.5, 0}));
    EXPECT_EQ(with.default_view, engine::DefaultView::from_plus_z);
    const SceneInfo other = g.registry.add({"model/gltf+json", gltf + " "}, no_files()).info;
    for (const auto& [id, camera] :
         {std::pair{with.id, Json()}, std::pair{other.id, Json::parse(R"({"position":[0,0,0],
                                                                        "look_at":[0,0,0]})")}}) {
        const fs::path meta = dir.path / "scenes" / id / "meta.json";
        std::ifstream in(meta);
        Json m = Json::parse(in);
        m["info"]["default_view"] = "sideways";
        m["info"]["camera"] = camera;
        std::ofstream(meta) << m.dump();
    }
    {
        Fixture k(dir.path.string());
        for (const std::string& id : {with.id, other.id}) {
            const auto before = k.registry.info(id);
            ASSERT_TRUE(before) << id;
            EXPECT_FALSE(before->camera);
            EXPECT_EQ(before->default_view, engine::DefaultView::from_plus_z);
            ASSERT_TRUE(k.registry.get(id));
            const auto after = k.registry.info(id);
            ASSERT_TRUE(after && after->camera) << id;
            EXPECT_EQ(after->camera->look_at, (engine::Vec3d{0.5, 0.5, 0}));
        }
    }
    // A camera is saved and read back exactly.
    const std::string with_camera = R"({"objects":[{"type":"sphere","center":[0,0,10],
        "radius":2}],"camera":{"position":[0.1,2,-3],"look_at":[0,0,10],"fov_y_deg":30}})";
    const std::string id = g.registry.add({"application/json", with_camera}, no_files()).info.id;
    Fixture h(dir.path.string());
    const auto info = h.registry.info(id);
    ASSERT_TRUE(info && info->camera);
    EXPECT_EQ(info->camera->position, (engine::Vec3d{0.1, 2, -3}));
    EXPECT_EQ(info->camera->up, (engine::Vec3d{0, 1, 0}));
    EXPECT_EQ(info->camera->fov_y_deg, 30.0);
}

// Two registries on one data dir, as two replicas are: each serves what the other registered,
// on demand, and a scene deleted through one is gone from the other once it looks on disk.
TEST(SceneRegistry, ReplicasShareADataDir) {
    TempDir dir;
    Fixture a(dir.path.string());
    Fixture b(dir.path.string());  // opened before a registers anything
    const auto added = a.registry.add({"application/json", kSpheres}, no_files());
    ASSERT_TRUE(added.created);
    const std::string id = added.info.id;
    auto info = b.registry.info(id);
    ASSERT_TRUE(info);
    EXPECT_EQ(info->spheres, 2u);
    auto engine = b.registry.get(id);
    ASSERT_TRUE(engine);
    EXPECT_EQ(engine->scene().objects.size(), 2u);
    // The same content posted to b: already registered (by a), built but not saved again.
    EXPECT_FALSE(b.registry.add({"application/json", kSpheres}, no_files()).created);
    const auto other = a.registry.add(
        {"application/json", R"({"objects":[{"type":"sphere","center":[0,0,5],"radius":1}]})"},
        no_files());
    ASSERT_EQ(b.registry.list().size(), 2u);  // the listing looks on disk too
    EXPECT_FALSE(b.registry.get("sc_not_a_scene"));
    EXPECT_FALSE(b.registry.info("../tmp"));  // only ids are looked up on disk
    // b knows `other` (listed) but has not loaded it; a deletes it; b answers unknown.
    ASSERT_TRUE(a.registry.remove(other.info.id));
    EXPECT_FALSE(b.registry.get(other.info.id));
    EXPECT_EQ(b.registry.size(), 1u);
}

// Threads of two registries racing to save the same scene into one data dir: every add
// succeeds, exactly one reports it created, the saved copy is whole, and tmp/ is left empty.
TEST(SceneRegistry, ConcurrentWritersOfOneIdCannotCorruptIt) {
    TempDir dir;
    Fixture a(dir.path.string());
    Fixture b(dir.path.string());
    std::atomic<int> created{0}, failed{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < 8; ++t) {
        threads.emplace_back([&, t] {
            try {
                auto& r = (t % 2 ? a : b).registry;
                created += r.add({"application/json", kSpheres}, no_files()).created ? 1 : 0;
            } catch (const std::exception&) {
                ++failed;
            }
        });
    }
    for (auto& t : threads)
        t.join();
    EXPECT_EQ(failed.load(), 0);
    EXPECT_EQ(created.load(), 1);  // the one whose rename published the copy
    EXPECT_TRUE(fs::is_empty(dir.path / "tmp"));
    Fixture c(dir.path.string());
    ASSERT_EQ(c.registry.size(), 1u);
    EXPECT_TRUE(c.registry.get(c.registry.list().at(0).id));
}

// A scene that cannot be saved is not acknowledged: the error names what failed, and the
// registry stays as it was.
TEST(SceneRegistry, ASceneThatCannotBeSavedIsNotRegistered) {
    TempDir dir;
    Fixture f(dir.path.string());
    fs::remove_all(dir.path / "tmp");
    {
        std::ofstream blocker(dir.path / "tmp");  // a file where the staging directory goes
    }
    try {
        f.registry.add({"application/json", kSpheres}, no_files());
        ADD_FAILURE() << "registered without saving";
    } catch (const ApiError& e) {
        EXPECT_EQ(e.code, ErrorCode::internal);
        EXPECT_NE(std::string(e.what()).find("cannot save the scene"), std::string::npos);
    }
    EXPECT_EQ(f.registry.size(), 0u);
    EXPECT_TRUE(fs::is_empty(dir.path / "scenes"));
}

TEST(SceneRegistry, DeleteRemovesSavedCopy) {
    TempDir dir;
    Fixture f(dir.path.string());
    const std::string id = f.registry.add({"application/json", kSpheres}, no_files()).info.id;
    EXPECT_TRUE(fs::exists(dir.path / "scenes" / id));
    EXPECT_TRUE(f.registry.remove(id));
    EXPECT_FALSE(f.registry.remove(id));
    EXPECT_FALSE(fs::exists(dir.path / "scenes" / id));
    EXPECT_FALSE(f.registry.get(id));
}

// A saved copy changed or cut on disk is refused when the scene is rebuilt from it, naming what
// is wrong, rather than built into a different scene under the same id (until 2026-12-05 a
// missing body was a bare 500 and a changed file was built as it was). DELETE then removes it,
// and the scene registers again.
TEST(SceneRegistry, DamagedSavedCopiesAreRefusedAndCanBeReplaced) {
    const std::string doc = R"({"objects":[{"type":"mesh","uri":"tri.obj"},
                                           {"type":"sphere","center":[0,0,10],"radius":2}]})";
    const std::string obj = "v 0 0 5\nv 1 0 5\nv 0 1 5\nf 1 2 3\n";
    const FileSource files = [&](const std::string& p) -> engine::Result<std::string> {
        if (p == "tri.obj")
            return obj;
        return engine::Status::error(engine::Code::invalid_scene, "no file " + p);
    };
    struct Damage {
        const char* what;     // expected in the message
        std::string file;     // in the saved copy's directory
        std::string content;  // empty: removed
    };
    // The mesh's saved copy is the file other than meta.json and body.
    for (const Damage& d : {Damage{"its body is missing", "body", ""},
                            Damage{"its body does not have the bytes", "body",
                                   R"({"objects":[{"type":"mesh","uri":"tri.obj"},
                                {"type":"sphere","center":[0,0,10],"radius":3}]})"},
                            Damage{"meta.json is unreadable", "meta.json", "{"},
                            Damage{"\"tri.obj\" is missing", "mesh", ""},
                            Damage{"\"tri.obj\" does not have the bytes", "mesh",
                                   "v 0 0 5\nv 2 0 5\nv 0 1 5\nf 1 2 3\n"}}) {
        TempDir dir;
        std::string id;
        {
            Fixture f(dir.path.string());
            id = f.registry.add({"application/json", doc}, files).info.id;
        }
        const fs::path saved = dir.path / "scenes" / id;
        fs::path target = saved / d.file;
        if (d.file == "mesh") {
            for (const auto& entry : fs::directory_iterator(saved)) {
                const std::string name = entry.path().filename().string();
                if (name != "meta.json" && name != "body")
                    target = entry.path();
            }
        }
        ASSERT_TRUE(fs::exists(target)) << target;
        if (d.content.empty()) {
            fs::remove(target);
        } else {
            std::ofstream(target, std::ios::binary | std::ios::trunc) << d.content;
        }
        Fixture g(dir.path.string());
        if (d.file == "meta.json") {
            // Unreadable, it makes the scene unknown (skipped when the data dir is opened);
            // registering the scene again replaces the damaged copy.
            EXPECT_FALSE(g.registry.get(id));
            EXPECT_EQ(g.registry.add({"application/json", doc}, files).info.id, id);
            Fixture h(dir.path.string());
            EXPECT_TRUE(h.registry.get(id)) << d.what;
            continue;
        }
        try {
            g.registry.get(id);
            ADD_FAILURE() << d.what << ": built";
        } catch (const ApiError& e) {
            EXPECT_EQ(e.code, ErrorCode::internal);
            EXPECT_NE(std::string(e.what()).find(d.what), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("DELETE the scene and register it again"),
                      std::string::npos)
                << e.what();
        }
        EXPECT_TRUE(g.registry.remove(id)) << d.what;
        EXPECT_EQ(g.registry.add({"application/json", doc}, files).info.id, id);
        auto engine = g.registry.get(id);
        ASSERT_TRUE(engine) << d.what;
        EXPECT_EQ(engine->scene().objects.size(), 2u);
        Fixture h(dir.path.string());  // and the new copy is whole
        EXPECT_TRUE(h.registry.get(id)) << d.what;
    }
}

TEST(SceneRegistry, EvictsLeastRecentlyUsedAndReloads) {
    TempDir dir;
    Fixture f(dir.path.string(), /*budget=*/1);  // every scene is over budget but the newest
    const std::string a = f.registry.add({"application/json", kSpheres}, no_files()).info.id;
    const std::string b =
        f.registry
            .add({"application/json",
                  R"({"objects":[{"type":"sphere","center":[1,2,3],"radius":1}]})"},
                 no_files())
            .info.id;
    EXPECT_EQ(f.registry.resident(), 1u);
    EXPECT_EQ(f.builds.load(), 2);
    auto engine = f.registry.get(a);  // evicted: rebuilt from the saved copy
    ASSERT_TRUE(engine);
    EXPECT_EQ(f.builds.load(), 3);
    EXPECT_EQ(engine->scene().objects.size(), 2u);
    EXPECT_EQ(f.registry.resident(), 1u);
    EXPECT_TRUE(f.registry.get(b));
}

// The first fast (or exact) query builds another BVH: the registry counts it from the next
// request on, in the resident total and in the scene's info.
TEST(SceneRegistry, CountsTheBvhsQueriesBuildLater) {
    Fixture f("");
    std::string spheres = R"({"objects":[)";
    for (int i = 0; i < 40; ++i) {  // past the brute-force threshold: an Embree BVH
        spheres += std::string(i ? "," : "") + R"({"type":"sphere","center":[)" +
                   std::to_string(3 * i) + R"(,0,10],"radius":1})";
    }
    spheres += "]}";
    const auto added = f.registry.add({"application/json", spheres}, no_files());
    const std::size_t before = f.registry.resident_bytes();
    EXPECT_EQ(added.info.memory_bytes, before);
    auto engine = f.registry.get(added.info.id);
    ASSERT_TRUE(engine);
    ASSERT_FALSE(engine->brute_force());
    EXPECT_EQ(f.registry.resident_bytes(), before);
    engine->intersect({engine::Ray{{0, 0, 0}, {0, 0, 1}}},
                      engine::QueryOptions{engine::Mode::closest, engine::Precision::fast});
    ASSERT_TRUE(f.registry.get(added.info.id));
    const std::size_t after = f.registry.resident_bytes();
    EXPECT_GT(after, before);
    EXPECT_EQ(after, engine->memory_bytes());
    EXPECT_EQ(f.registry.info(added.info.id)->memory_bytes, after);
}

TEST(SceneRegistry, ConcurrentAddsAndGets) {
    Fixture f("");
    std::vector<std::thread> threads;
    std::atomic<int> created{0};
    for (int t = 0; t < 8; ++t) {
        threads.emplace_back([&, t] {
            for (int i = 0; i < 20; ++i) {
                const std::string doc = R"({"objects":[{"type":"sphere","center":[0,0,)" +
                                        std::to_string(i % 5) + R"(],"radius":1}]})";
                auto added = f.registry.add({"application/json", doc}, no_files());
                if (added.created)
                    ++created;
                EXPECT_TRUE(f.registry.get(added.info.id)) << t;
            }
        });
    }
    for (auto& th : threads)
        th.join();
    EXPECT_EQ(f.registry.size(), 5u);
    EXPECT_EQ(created.load(), 5);
}

}  // namespace
}  // namespace raycastd::server
