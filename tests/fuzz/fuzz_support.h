#pragma once
// What the fuzz targets share: how a failed property becomes a crash libFuzzer keeps, the
// two-file input of the model loaders (a model and the one resource it may refer to), and the
// invariants every loaded model must keep whatever the bytes were.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "engine/load/model_loader.h"

namespace raycastd::fuzz {

/// Prints `what` and aborts: libFuzzer takes the signal for a crash and saves the input.
[[noreturn]] inline void fail(const std::string& what) {
    std::fprintf(stderr, "fuzz property broken: %s\n", what.c_str());
    std::fflush(stderr);
    std::abort();
}

/// The input's bytes as a string_view.
inline std::string_view bytes_of(const std::uint8_t* data, std::size_t size) {
    return {reinterpret_cast<const char*>(data), size};
}

/// A model input is `model [kResourceMarker resource]`: the model's bytes, then, optionally,
/// the bytes every URI it refers to (an external glTF buffer, an OBJ mtllib) reads as. The
/// seeds (tests/fuzz/make_seeds.py) put a model's first external file there.
constexpr std::string_view kResourceMarker = "\n--raycastd-fuzz-resource--\n";

struct ModelInput {
    std::string_view model;
    std::string_view resource;
    bool has_resource = false;
};

inline ModelInput split_model_input(std::string_view bytes) {
    const std::size_t at = bytes.find(kResourceMarker);
    if (at == std::string_view::npos)
        return {bytes, {}, false};
    return {bytes.substr(0, at), bytes.substr(at + kResourceMarker.size()), true};
}

/// Reads every URI as `in.resource` (copied, as a file read would), or refuses everything
/// when there is none.
inline engine::ResourceReader resource_reader(const ModelInput& in) {
    if (!in.has_resource)
        return engine::no_resources();
    std::string resource(in.resource);
    return [resource](const std::string&) -> engine::Result<std::string> { return resource; };
}

/// Checks what load_model promises of a model it returns (model_loader.h): every index in
/// range, one material per triangle or none, one normal per vertex or none, names for every
/// material, limits kept.
inline void check_model(const engine::LoadedModel& m, const engine::LoadLimits& limits) {
    if (m.material_names.size() != m.materials.size())
        fail("material_names and materials differ in length");
    std::size_t triangles = 0, vertices = 0;
    for (const engine::ModelPart& part : m.parts) {
        const engine::TriangleMesh& mesh = part.mesh;
        triangles += mesh.triangles.size();
        vertices += mesh.positions.size();
        for (const auto& p : mesh.positions) {
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
                fail(part.name + ": a position is not finite");
        }
        for (const auto& t : mesh.triangles) {
            for (std::uint32_t v : t) {
                if (v >= mesh.positions.size())
                    fail(part.name + ": vertex index " + std::to_string(v) + " out of range");
            }
        }
        if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size())
            fail(part.name + ": normals are neither per vertex nor absent");
        if (!mesh.triangle_material.empty()) {
            if (mesh.triangle_material.size() != mesh.triangles.size())
                fail(part.name + ": triangle_material is neither per triangle nor absent");
            for (std::uint32_t k : mesh.triangle_material) {
                if (k >= m.materials.size())
                    fail(part.name + ": material index " + std::to_string(k) + " out of range");
            }
        }
    }
    if (triangles != m.triangle_count())
        fail("triangle_count() disagrees with the parts");
    if (triangles > limits.max_triangles || vertices > limits.max_vertices)
        fail("a model over the load limits was returned");
}

/// Limits small enough that a fuzz input cannot spend seconds on a legitimately huge model.
inline engine::LoadLimits fuzz_limits() {
    engine::LoadLimits l;
    l.max_triangles = 200'000;
    l.max_vertices = 600'000;
    return l;
}

/// Loads `in.model` as `format` through in's resource reader: a model that loads must pass
/// check_model, and a failure must be a data error (Code::internal is an exception nobody
/// expected).
inline void load_and_check(const ModelInput& in, engine::ModelFormat format) {
    const engine::LoadLimits limits = fuzz_limits();
    auto loaded = engine::load_model(in.model, format, resource_reader(in), "fuzz", limits);
    if (loaded.ok()) {
        check_model(*loaded, limits);
    } else if (loaded.status().code == engine::Code::ok ||
               loaded.status().code == engine::Code::internal) {
        fail("load_model failed with code " +
             std::to_string(static_cast<int>(loaded.status().code)) + ": " +
             loaded.status().message);
    }
}

}  // namespace raycastd::fuzz
