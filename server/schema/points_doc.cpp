#include "server/schema/points_doc.h"

#include "server/schema/json_writer.h"

namespace raycastd::server {

namespace {

constexpr ErrorCode kInvalidRequest = ErrorCode::invalid_request;

engine::Vec3d parse_point(const Json& j, const std::string& path, std::size_t index) {
    if (!j.is_array() || j.size() != 3 || !j.at(0).is_number() || !j.at(1).is_number() ||
        !j.at(2).is_number()) {
        throw ApiError(kInvalidRequest,
                       "point " + std::to_string(index) + " must be [x, y, z]: three numbers",
                       path);
    }
    // read_vec3 turns a number that overflowed to ±inf into bad_json.
    return read_vec3(j, path, kInvalidRequest);
}

void write_entry(JsonWriter& w, const engine::Scene& scene, engine::PointQuery query,
                 const engine::PointAnswer& a) {
    switch (query) {
        case engine::PointQuery::closest: {
            const engine::PointHit& h = a.hit;
            if (!h.valid()) {
                w.raw("{\"found\":false}");
                return;
            }
            w.raw("{\"found\":true,\"point\":").vec(h.point);
            w.raw(",\"distance\":").number(h.distance);
            w.raw(",\"object\":").integer(h.object);
            w.raw(",\"name\":").string(scene.objects[h.object].name);
            w.raw(",\"primitive\":").integer(h.primitive);
            w.raw(",\"barycentric\":[").number(h.u).ch(',').number(h.v).ch(']');
            w.raw(",\"normal\":").vec(h.normal).ch('}');
            return;
        }
        case engine::PointQuery::distance:
        case engine::PointQuery::signed_distance:
            w.raw("{\"distance\":").number(a.distance).ch('}');  // +inf → null
            return;
        case engine::PointQuery::occupancy:
            w.raw("{\"inside\":").boolean(a.inside);
            w.raw(",\"winding\":").number(a.winding).ch('}');
            return;
    }
}

}  // namespace

engine::PointQuery parse_point_query(const std::string& name, const std::string& path) {
    if (auto q = engine::point_query_from_string(name))
        return *q;
    throw ApiError(
        kInvalidRequest,
        "unknown query \"" + name + "\" (expected closest, distance, signed_distance, occupancy)",
        path);
}

double parse_max_distance(double value, const std::string& path) {
    if (!(value >= 0))
        throw ApiError(kInvalidRequest, "max_distance must be a number >= 0", path);
    return value;
}

PointsRequest parse_points_request(const Json& body, const std::string& prefix,
                                   std::size_t max_points) {
    require_object(body, prefix, kInvalidRequest);
    PointsRequest req;
    if (const Json* q = member(body, "query")) {
        const std::string path = prefix + "/query";
        req.options.query = parse_point_query(read_string(*q, path, kInvalidRequest), path);
    }
    if (const Json* m = member(body, "max_distance")) {
        const std::string path = prefix + "/max_distance";
        req.options.max_distance = parse_max_distance(read_number(*m, path, kInvalidRequest), path);
    }
    const Json* pts = member(body, "points");
    const std::string ppath = prefix + "/points";
    if (!pts)
        throw ApiError(kInvalidRequest, ppath + " is required", ppath);
    if (!pts->is_array())
        throw ApiError(kInvalidRequest, ppath + " must be an array of [x, y, z]", ppath);
    if (pts->size() > max_points) {
        throw ApiError(ErrorCode::too_large,
                       std::to_string(pts->size()) + " points is over the limit of " +
                           std::to_string(max_points) + " per request",
                       ppath);
    }
    req.points.reserve(pts->size());
    for (std::size_t i = 0; i < pts->size(); ++i)
        req.points.push_back(parse_point(pts->at(i), child_path(ppath, i), i));
    return req;
}

std::string write_points_response(const engine::Scene& scene, engine::PointQuery query,
                                  const std::vector<engine::PointAnswer>& answers) {
    std::string out;
    out.reserve(48 + answers.size() * (query == engine::PointQuery::closest ? 200 : 24));
    JsonWriter w(out);
    w.raw("{\"query\":").string(engine::to_string(query)).raw(",\"results\":[");
    for (std::size_t i = 0; i < answers.size(); ++i) {
        if (i)
            w.ch(',');
        write_entry(w, scene, query, answers[i]);
    }
    w.raw("]}");
    return out;
}

}  // namespace raycastd::server
