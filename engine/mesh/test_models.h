#pragma once
// The published models of ../shared/data/models as single mesh objects, for the tests of mesh/
// and points/ (engine/testing sits below load/, so this helper lives here). Tests skip cleanly
// when a model is absent: GTEST_SKIP() << "models not found at " << models_dir().

#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>

#include "engine/load/model_loader.h"
#include "engine/scene/scene.h"

namespace raycastd::engine::testing {

/// ../shared/data/models (RAYCASTD_SHARED_DIR).
inline std::filesystem::path models_dir() {
    return std::filesystem::path(RAYCASTD_SHARED_DIR) / "data" / "models";
}

/// A published model under models_dir() as one mesh object (its parts merged, world space), or
/// nullopt when the file is absent or does not load.
inline std::optional<Object> model_object(const std::string& relative) {
    const auto path = models_dir() / relative;
    std::ifstream f(path, std::ios::binary);
    if (!f)
        return std::nullopt;
    std::stringstream ss;
    ss << f.rdbuf();
    const auto format = format_from_name(relative);
    if (!format)
        return std::nullopt;
    auto model = load_model(ss.str(), *format, no_resources(), relative);
    if (!model.ok() || model->parts.empty())
        return std::nullopt;
    auto mesh = std::make_shared<TriangleMesh>();
    for (const ModelPart& part : model->parts) {
        const auto base = static_cast<std::uint32_t>(mesh->positions.size());
        mesh->positions.insert(mesh->positions.end(), part.mesh.positions.begin(),
                               part.mesh.positions.end());
        for (auto t : part.mesh.triangles)
            mesh->triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    }
    Object o;
    o.kind = ObjectKind::mesh;
    o.name = relative;
    o.mesh = std::move(mesh);
    return o;
}

}  // namespace raycastd::engine::testing
