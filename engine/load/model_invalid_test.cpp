// The loaders against the broken and edge-case files of shared/data/models/invalid: nothing
// crashes, and glTF files whose glTF-Validator report (the `.report.json` oracle beside each
// file) lists an error that leaves the geometry unreadable are rejected. Skipped when the
// corpus is absent.

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/load/model_loader.h"

namespace raycastd::engine {
namespace {

namespace fs = std::filesystem;

fs::path invalid_dir() {
    return fs::path(RAYCASTD_SHARED_DIR) / "data" / "models" / "invalid";
}

#define REQUIRE_INVALID_MODELS()                                          \
    if (!fs::is_directory(invalid_dir())) {                               \
        GTEST_SKIP() << "models not found at " << invalid_dir().string(); \
    }

std::string read_bytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

ResourceReader dir_reader(const fs::path& dir) {
    return [dir](const std::string& uri) -> Result<std::string> {
        fs::path p = dir / uri;
        if (!fs::is_regular_file(p))
            return Status::error(Code::not_found, uri + " not found");
        return read_bytes(p);
    };
}

Result<LoadedModel> load_file(const fs::path& p) {
    auto format = format_from_name(p.filename().string());
    if (!format)
        return Status::error(Code::unsupported_format, "no format for " + p.string());
    return load_model(read_bytes(p), *format, dir_reader(p.parent_path()), p.filename().string());
}

/// What every successful load guarantees, whatever the input.
void expect_consistent(const LoadedModel& model) {
    for (const ModelPart& part : model.parts) {
        for (const auto& t : part.mesh.triangles) {
            for (std::uint32_t v : t)
                ASSERT_LT(v, part.mesh.positions.size());
        }
        for (const Vec3d& p : part.mesh.positions)
            ASSERT_TRUE(is_finite(p));
        ASSERT_TRUE(part.mesh.normals.empty() ||
                    part.mesh.normals.size() == part.mesh.positions.size());
        ASSERT_TRUE(part.mesh.triangle_material.empty() ||
                    part.mesh.triangle_material.size() == part.mesh.size());
        for (std::uint32_t m : part.mesh.triangle_material)
            ASSERT_LT(m, model.materials.size());
    }
    ASSERT_EQ(model.materials.size(), model.material_names.size());
}

std::vector<fs::path> model_files_under(const fs::path& dir) {
    std::vector<fs::path> out;
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
        if (e.is_regular_file() && format_from_name(e.path().filename().string()))
            out.push_back(e.path());
    }
    std::sort(out.begin(), out.end());
    return out;
}

TEST(ModelInvalid, NothingUnderInvalidCrashesAndSuccessesAreConsistent) {
    REQUIRE_INVALID_MODELS();
    std::size_t loaded = 0, rejected = 0;
    for (const fs::path& p : model_files_under(invalid_dir())) {
        SCOPED_TRACE(p.string());
        auto model = load_file(p);
        if (model.ok()) {
            ++loaded;
            expect_consistent(*model);
        } else {
            ++rejected;
            EXPECT_NE(model.status().code, Code::ok);
            EXPECT_FALSE(model.status().message.empty());
            EXPECT_NE(model.status().code, Code::internal) << model.status().message;
        }
    }
    EXPECT_GT(loaded, 0u);
    EXPECT_GT(rejected, 0u);
}

/// True when the validator issue (error severity) means the file's geometry cannot be read as
/// stored: a byte range or index out of bounds, a broken container, unparseable JSON, a node
/// cycle, or an unresolved reference on the path from the scene to the vertex data.
bool geometry_unusable(const std::string& code, const std::string& pointer) {
    static const std::set<std::string> kAlways = {"ACCESSOR_TOO_LONG",
                                                  "BUFFER_VIEW_TOO_LONG",
                                                  "ACCESSOR_INDEX_OOB",
                                                  "BUFFER_BYTE_LENGTH_MISMATCH",
                                                  "BUFFER_MISSING_GLB_DATA",
                                                  "INVALID_JSON",
                                                  "NODE_LOOP",
                                                  "ACCESSOR_SPARSE_COUNT_OUT_OF_RANGE",
                                                  "UNKNOWN_ASSET_MAJOR_VERSION"};
    if (kAlways.count(code) || code.rfind("GLB_", 0) == 0)
        return true;
    auto under = [&](const char* prefix) { return pointer.rfind(prefix, 0) == 0; };
    if (code == "IO_ERROR" || code == "INVALID_URI")
        return under("/buffers/");
    if (code == "UNRESOLVED_REFERENCE") {
        auto has = [&](const char* part) { return pointer.find(part) != std::string::npos; };
        const bool node_link = under("/nodes/") && (has("/children") || has("/mesh") ||
                                                    has("/camera") || has("KHR_lights_punctual"));
        const bool mesh_link = under("/meshes/") && !has("/targets/");
        return under("/accessors/") || under("/bufferViews/") || under("/scene") || node_link ||
               mesh_link;
    }
    return false;
}

TEST(ModelInvalid, GltfValidatorOraclesSayWhatMustBeRejected) {
    REQUIRE_INVALID_MODELS();
    std::size_t must_reject = 0;
    for (const fs::path& p : model_files_under(invalid_dir() / "gltf-validator")) {
        fs::path report = p;
        report += ".report.json";
        if (!fs::exists(report))
            continue;
        nlohmann::json r = nlohmann::json::parse(read_bytes(report));
        std::string reason;
        for (const auto& m : r.at("issues").at("messages")) {
            if (m.at("severity").get<int>() != 0)
                continue;
            const std::string code = m.at("code").get<std::string>();
            const std::string pointer = m.value("pointer", std::string());
            if (geometry_unusable(code, pointer))
                reason = code + " at '" + pointer + "'";
        }
        // A UTF-8 byte-order mark is INVALID_JSON to the validator (glTF JSON must not start with
        // one) but leaves the data intact; like nlohmann/json we read through it.
        if (reason.empty() || p.stem() == "bom")
            continue;
        ++must_reject;
        auto model = load_file(p);
        EXPECT_FALSE(model.ok()) << p.string() << " should be rejected (" << reason << ")";
    }
    EXPECT_GT(must_reject, 50u);
}

// Hand-picked files from other sources whose README entry says the geometry is broken.
TEST(ModelInvalid, KnownBrokenFilesAreRejected) {
    REQUIRE_INVALID_MODELS();
    for (const char* rel : {
             "tinygltf/BoundsChecking/integer-out-of-bounds.gltf",
             "tinygltf/BoundsChecking/invalid-buffer-index.gltf",
             "tinygltf/BoundsChecking/invalid-buffer-view-index.gltf",
             "tinygltf/BoundsChecking/invalid-primitive-indices.gltf",
             "assimp/IndexOutOfRange/IndexOutOfRange.gltf",
             "assimp/IndexOutOfRange/AllIndicesOutOfRange.gltf",
             "assimp/RecursiveNodes/RecursiveNodes.gltf",
             "assimp/MissingBin/BoxTextured.gltf",
             "assimp/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb",
             "draco/Box_Draco/Box_Draco.glb",
             "obj/tinyobjloader/invalid-relative-vertex-index.obj",
             "obj/tinyobjloader/issue-140-zero-face-idx.obj",
         }) {
        SCOPED_TRACE(rel);
        auto model = load_file(invalid_dir() / rel);
        ASSERT_FALSE(model.ok());
        EXPECT_EQ(model.status().code, Code::model_load_failed) << model.status().message;
    }
}

}  // namespace
}  // namespace raycastd::engine
