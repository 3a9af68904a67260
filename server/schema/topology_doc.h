#pragma once
// The `topology` entries of a scene response (docs/api.md, "POST /v1/scenes"): one per mesh
// object, from the half-edge counts the engine computed when it built the scene
// (engine/mesh/topology.h), written into the response and into the registry's saved copy of the
// scene's info (so that GET /v1/scenes/{id} after a restart shows them without a rebuild).

#include <cstdint>
#include <string>
#include <vector>

#include "engine/mesh/topology.h"
#include "engine/query/intersect.h"
#include "server/schema/json_read.h"
#include "server/schema/json_writer.h"

namespace raycastd::server {

/// One mesh object's topology.
struct TopologyEntry {
    std::uint32_t object = 0;
    std::string name;
    engine::MeshTopology topology;
};

/// The entries of the scene's mesh objects (`"type": "mesh"`, and the objects of a raw model
/// file), in object order; spheres and lone triangles have none.
std::vector<TopologyEntry> topology_entries(const engine::QueryEngine& engine);

/// `[{"object": 0, "name": ..., "vertices": ..., ..., "sign": "winding"}, ...]`.
void write_topology(JsonWriter& w, const std::vector<TopologyEntry>& entries);

/// The entries as a JSON document and back (the registry's meta.json); from_json throws
/// nlohmann's exceptions on a malformed document, as the registry's other readers do.
Json topology_to_json(const std::vector<TopologyEntry>& entries);
std::vector<TopologyEntry> topology_from_json(const Json& j);

}  // namespace raycastd::server
