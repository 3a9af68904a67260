// A POST /v1/scenes body as the route takes it: classify_scene_body (scene document or model),
// then ModelSource::build_scene — parse_json, the scene document → engine::Scene
// (scene_from_document, mesh objects loaded through load_model) or scene_from_model, then the
// prepared QueryEngine. Files a document names come from a fixed in-memory map (kFiles), so
// `uri`s, relative resources and confinement are exercised without a file system. Any bad
// input must be an ApiError of the API's table other than internal; a scene that builds must
// pass engine::validate and answer a few rays.

#include <cmath>
#include <cstring>
#include <exception>
#include <map>
#include <new>
#include <vector>

#include "engine/query/intersect.h"
#include "server/api_error.h"
#include "server/model_source.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

using namespace raycastd;

std::string float_bytes(std::initializer_list<float> values) {
    std::string out(values.size() * sizeof(float), '\0');
    std::memcpy(out.data(), values.begin(), out.size());
    return out;
}

/// The files a fuzzed document can name (the seeds name each of them).
const std::map<std::string, std::string>& files() {
    static const std::map<std::string, std::string> kFiles = {
        {"tri.obj", "mtllib tri.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n"},
        {"tri.mtl", "newmtl red\nKd 1 0 0\nNs 10\n"},
        {"tri.stl",
         "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
         "vertex 0 1 0\nendloop\nendfacet\nendsolid t\n"},
        {"quad.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"},
        {"tri.ply",
         "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
         "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
         "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"},
        {"models/tri.gltf",
         R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],)"
         R"("nodes":[{"mesh":0,"translation":[0,0,1]}],)"
         R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],)"
         R"("buffers":[{"uri":"bin/tri.bin","byteLength":36}],)"
         R"("bufferViews":[{"buffer":0,"byteLength":36}],)"
         R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",)"
         R"("min":[0,0,0],"max":[1,1,0]}]})"},
        {"models/bin/tri.bin", float_bytes({0, 0, 0, 1, 0, 0, 0, 1, 0})},
    };
    return kFiles;
}

engine::Result<std::string> read_file(const std::string& path) {
    const auto it = files().find(path);
    if (it == files().end())
        return engine::Status::error(engine::Code::not_found, path + " not found");
    return it->second;
}

server::Limits fuzz_limits() {
    server::Limits l;
    l.max_body_bytes = 1u << 20;
    l.max_rays = 64;
    l.max_triangles = 20'000;
    return l;
}

/// A few rays through the scene's bounds and past it.
void trace(const engine::QueryEngine& engine) {
    const engine::Bounds3 b = engine.scene().bounds();
    std::vector<engine::Ray> rays(3);
    rays[0].direction = {0, 0, 1};
    rays[1].origin = {0, 0, -10};
    rays[1].direction = {0.1, 0.2, 1};
    rays[2].direction = {1, 1, 1};
    if (std::isfinite(b.lo.x) && std::isfinite(b.hi.x)) {
        rays[2].origin = b.lo - engine::Vec3d{1, 1, 1};
    }
    for (engine::Mode mode : {engine::Mode::closest, engine::Mode::all}) {
        engine::QueryOptions options;
        options.mode = mode;
        (void)engine.intersect(rays, options);
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const server::ModelSource models(fuzz_limits(), "/nonexistent-scene-root");
    const std::string body(fuzz::bytes_of(data, size));
    try {
        const std::string type = server::classify_scene_body(body, "");
        const auto engine = models.build_scene(server::SceneSource{type, body}, read_file);
        if (!engine)
            fuzz::fail("build_scene returned no scene");
        const engine::Status st = engine::validate(engine->scene());
        if (!st.ok())
            fuzz::fail("a built scene fails validate: " + st.message + " at " + st.path);
        trace(*engine);
    } catch (const server::ApiError& e) {
        if (e.code == server::ErrorCode::internal)
            fuzz::fail(std::string("internal error (a 500): ") + e.what());
    } catch (const std::bad_alloc&) {
        // 413 too_large in the server (App::handle).
    } catch (const std::exception& e) {
        fuzz::fail(std::string("a non-API exception (a 500): ") + e.what());
    }
    return 0;
}
