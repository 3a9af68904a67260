// Load + registry time for the published sample models and a generated ≥1M-triangle model,
// beside the file size, and memory per triangle (issue 3).
//
//   bench_load [--shared DIR] [--quick]
//
// For each file: the bytes are read once (not timed), then timed separately:
//   parse   engine::load_model (tinygltf / our readers → world-space meshes)
//   build   engine::QueryEngine::build (validation + Embree BVH above 16 primitives)
//   sha256  the content hash the registry computes for the id
// memory/tri is QueryEngine::memory_bytes() / triangles (our positions, indices and normals in
// double precision plus Embree's BVH estimate), and RSS growth is measured around the build.

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "bench/bench_files.h"
#include "bench/workloads.h"
#include "engine/load/model_loader.h"
#include "engine/process_memory.h"
#include "engine/query/intersect.h"
#include "server/content_hash.h"

namespace fs = std::filesystem;
using namespace raycastd;

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::string read_bytes(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

void row(const std::string& name, const std::string& bytes, engine::ModelFormat format,
         const engine::ResourceReader& reader) {
    auto t0 = std::chrono::steady_clock::now();
    const std::string id = server::sha256_hex(bytes);
    const double hash_ms = ms_since(t0);
    t0 = std::chrono::steady_clock::now();
    auto model = engine::load_model(bytes, format, reader, name);
    const double parse_ms = ms_since(t0);
    if (!model.ok()) {
        std::printf("| %s | %.1f | load failed: %s |\n", name.c_str(), bytes.size() / 1e3,
                    model.status().message.c_str());
        return;
    }
    auto scene = std::make_shared<engine::Scene>();
    scene->materials.push_back(engine::Material{});
    for (auto& part : model->parts) {
        engine::Object o;
        o.kind = engine::ObjectKind::mesh;
        o.name = part.name;
        part.mesh.triangle_material.clear();
        o.mesh = std::make_shared<engine::TriangleMesh>(std::move(part.mesh));
        scene->objects.push_back(std::move(o));
    }
    const std::size_t tris = scene->triangle_count();
    const std::size_t rss0 = raycastd::engine::process_resident_bytes();
    t0 = std::chrono::steady_clock::now();
    auto engine = engine::QueryEngine::build(scene);
    const double build_ms = ms_since(t0);
    const std::size_t rss1 = raycastd::engine::process_resident_bytes();
    if (!engine.ok()) {
        std::printf("| %s | build failed: %s |\n", name.c_str(), engine.status().message.c_str());
        return;
    }
    const double per_tri = tris ? double((*engine)->memory_bytes()) / double(tris) : 0.0;
    std::printf("| %s | %.1f | %zu | %.2f | %.2f | %.2f | %.2f | %.0f | %.1f |\n", name.c_str(),
                bytes.size() / 1e3, tris, parse_ms, build_ms, hash_ms,
                parse_ms + build_ms + hash_ms, per_tri,
                tris ? double(rss1 > rss0 ? rss1 - rss0 : 0) / double(tris) : 0.0);
}

}  // namespace

int main(int argc, char** argv) {
    fs::path shared = RAYCASTD_SHARED_DIR;
    bool quick = false;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--shared" && i + 1 < argc)
            shared = argv[++i];
        if (a == "--quick")
            quick = true;
    }
    std::printf(
        "| model | file kB | triangles | parse ms | build ms | sha256 ms | total ms | "
        "memory B/tri | RSS growth B/tri |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    const fs::path models = shared / "data" / "models";
    const char* files[] = {
        "Duck/glTF-Binary/Duck.glb",
        "CesiumMilkTruck/glTF-Binary/CesiumMilkTruck.glb",
        "2CylinderEngine/glTF-Binary/2CylinderEngine.glb",
        "BoxTextured/glTF/BoxTextured.gltf",
        "stanford-bunny/stanford-bunny.obj",
        "bunny_ply/bunny.ply",
        "Wuson/Wuson.stl",
        "fandisk/fandisk.obj",
        "ballA_off/ballA.off",
        "teapot_stl/teapot.stl",
    };
    if (fs::exists(models)) {
        for (const char* f : files) {
            const fs::path p = models / f;
            if (!fs::exists(p))
                continue;
            const auto format = engine::format_from_name(p.filename().string());
            const fs::path dir = p.parent_path();
            engine::ResourceReader reader =
                [&dir](const std::string& uri) -> engine::Result<std::string> {
                return read_bytes(dir / uri);
            };
            row(f, read_bytes(p), *format, reader);
        }
    } else {
        std::printf("(models not found at %s: sample models skipped)\n", models.c_str());
    }
    // A generated model of ≥1M triangles, written as binary PLY and loaded back.
    const bench::Workload big =
        quick ? bench::make_icosphere_field(20, 4, 7) : bench::make_icosphere_field(200, 4, 7);
    const fs::path ply = fs::temp_directory_path() / "raycastd_bench_load.ply";
    if (bench::write_ply(ply.string(), big)) {
        row(std::string("generated: ") + big.description + " (binary PLY)", read_bytes(ply),
            engine::ModelFormat::ply, engine::no_resources());
        fs::remove(ply);
    }
    return 0;
}
