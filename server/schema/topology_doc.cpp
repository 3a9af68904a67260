#include "server/schema/topology_doc.h"

namespace raycastd::server {

std::vector<TopologyEntry> topology_entries(const engine::QueryEngine& engine) {
    std::vector<TopologyEntry> out;
    const engine::Scene& s = engine.scene();
    for (std::uint32_t i = 0; i < s.objects.size(); ++i) {
        if (s.objects[i].kind == engine::ObjectKind::mesh)
            out.push_back({i, s.objects[i].name, engine.topology()[i]});
    }
    return out;
}

void write_topology(JsonWriter& w, const std::vector<TopologyEntry>& entries) {
    w.ch('[');
    for (std::size_t k = 0; k < entries.size(); ++k) {
        const engine::MeshTopology& t = entries[k].topology;
        if (k)
            w.ch(',');
        w.raw("{\"object\":").integer(entries[k].object);
        w.raw(",\"name\":").string(entries[k].name);
        w.raw(",\"vertices\":").integer(t.vertices);
        w.raw(",\"triangles\":").integer(t.triangles);
        w.raw(",\"closed\":").boolean(t.closed);
        w.raw(",\"boundary_edges\":").integer(t.boundary_edges);
        w.raw(",\"boundary_loops\":").integer(t.boundary_loops);
        w.raw(",\"non_manifold_edges\":").integer(t.non_manifold_edges);
        w.raw(",\"non_manifold_vertices\":").integer(t.non_manifold_vertices);
        w.raw(",\"components\":").integer(t.components);
        w.raw(",\"euler_characteristic\":");
        if (t.euler_characteristic < 0)
            w.ch('-');
        w.integer(static_cast<std::uint64_t>(t.euler_characteristic < 0 ? -t.euler_characteristic
                                                                        : t.euler_characteristic));
        w.raw(",\"consistently_oriented\":").boolean(t.consistently_oriented);
        w.raw(",\"degenerate_triangles\":").integer(t.degenerate_triangles);
        w.raw(",\"refused_triangles\":").integer(t.refused_triangles);
        w.raw(",\"half_edge\":").boolean(t.half_edge);
        w.raw(",\"sign\":").string(engine::to_string(t.sign)).ch('}');
    }
    w.ch(']');
}

Json topology_to_json(const std::vector<TopologyEntry>& entries) {
    std::string text;
    JsonWriter w(text);
    write_topology(w, entries);
    return Json::parse(text);
}

std::vector<TopologyEntry> topology_from_json(const Json& j) {
    std::vector<TopologyEntry> out;
    for (const Json& e : j) {
        TopologyEntry t;
        t.object = e.at("object").get<std::uint32_t>();
        t.name = e.at("name").get<std::string>();
        engine::MeshTopology& m = t.topology;
        m.vertices = e.at("vertices").get<std::size_t>();
        m.triangles = e.at("triangles").get<std::size_t>();
        m.closed = e.at("closed").get<bool>();
        m.boundary_edges = e.at("boundary_edges").get<std::size_t>();
        m.boundary_loops = e.at("boundary_loops").get<std::size_t>();
        m.non_manifold_edges = e.at("non_manifold_edges").get<std::size_t>();
        m.non_manifold_vertices = e.at("non_manifold_vertices").get<std::size_t>();
        m.components = e.at("components").get<std::size_t>();
        m.euler_characteristic = e.at("euler_characteristic").get<std::int64_t>();
        m.consistently_oriented = e.at("consistently_oriented").get<bool>();
        m.degenerate_triangles = e.at("degenerate_triangles").get<std::size_t>();
        m.refused_triangles = e.at("refused_triangles").get<std::size_t>();
        m.half_edge = e.at("half_edge").get<bool>();
        m.sign = e.at("sign").get<std::string>() == "parity" ? engine::SignMethod::parity
                                                             : engine::SignMethod::winding;
        out.push_back(std::move(t));
    }
    return out;
}

}  // namespace raycastd::server
