// The points request's schema: JSON parsing and its errors, the response shapes, the binary
// records both ways, and the topology entries' JSON round trip.

#include "server/schema/points_doc.h"

#include <cmath>
#include <cstring>
#include <limits>

#include <gtest/gtest.h>

#include "server/schema/points_codec.h"
#include "server/schema/topology_doc.h"

namespace raycastd::server {
namespace {

ApiError request_error(const std::string& text, std::size_t max_points = 100) {
    try {
        parse_points_request(Json::parse(text), "", max_points);
    } catch (const ApiError& e) {
        return e;
    }
    ADD_FAILURE() << "no error for " << text;
    return ApiError(ErrorCode::internal, "");
}

TEST(PointsDoc, ParsesPointsAndOptions) {
    const PointsRequest r = parse_points_request(
        Json::parse(R"({"points": [[0,0,0],[1,2,3.5]], "query": "signed_distance",
                        "max_distance": 2})"),
        "", 100);
    ASSERT_EQ(r.points.size(), 2u);
    EXPECT_EQ(r.points[1], (engine::Vec3d{1, 2, 3.5}));
    EXPECT_EQ(r.options.query, engine::PointQuery::signed_distance);
    EXPECT_EQ(r.options.max_distance, 2.0);
    const PointsRequest d = parse_points_request(Json::parse(R"({"points": []})"), "", 100);
    EXPECT_EQ(d.options.query, engine::PointQuery::closest);
    EXPECT_EQ(d.options.max_distance, engine::kInfinity);
}

TEST(PointsDoc, BadPointsNameTheIndex) {
    for (const char* bad :
         {R"({"points": [[0,0,0], [1,2]]})", R"({"points": [[0,0,0], "x"]})",
          R"({"points": [[0,0,0], [1,2,"3"]]})", R"({"points": [[0,0,0], [1,2,3,4]]})"}) {
        const ApiError e = request_error(bad);
        EXPECT_EQ(e.code, ErrorCode::invalid_request) << bad;
        EXPECT_EQ(e.path, "/points/1") << bad;
        EXPECT_NE(std::string(e.what()).find("point 1"), std::string::npos) << e.what();
    }
    EXPECT_EQ(request_error(R"({"query": "closest"})").path, "/points");
    EXPECT_EQ(request_error(R"({"points": {}})").code, ErrorCode::invalid_request);
    EXPECT_EQ(request_error(R"({"points": [[0,0,0]], "query": "nearest"})").path, "/query");
    EXPECT_EQ(request_error(R"({"points": [[0,0,0]], "max_distance": -1})").path, "/max_distance");
    EXPECT_EQ(request_error(R"({"points": [[0,0,0],[0,0,0],[0,0,0]]})", 2).code,
              ErrorCode::too_large);
    EXPECT_EQ(request_error(R"([1, 2])").code, ErrorCode::invalid_request);
}

engine::Scene two_objects() {
    engine::Scene s;
    s.objects.resize(2);
    s.objects[0].name = "ball";
    s.objects[1].name = "tri \"1\"";
    return s;
}

TEST(PointsDoc, ResponseShapes) {
    const engine::Scene s = two_objects();
    engine::PointAnswer found;
    found.hit.point = {1, 2, 3};
    found.hit.distance = 0.5;
    found.hit.object = 1;
    found.hit.primitive = 7;
    found.hit.u = 0.25;
    found.hit.v = 0.5;
    found.hit.normal = {0, 0, 1};
    const std::vector<engine::PointAnswer> answers = {found, engine::PointAnswer{}};
    EXPECT_EQ(write_points_response(s, engine::PointQuery::closest, answers),
              R"({"query":"closest","results":[{"found":true,"point":[1,2,3],"distance":0.5,)"
              R"("object":1,"name":"tri \"1\"","primitive":7,"barycentric":[0.25,0.5],)"
              R"("normal":[0,0,1]},{"found":false}]})");
    engine::PointAnswer inside;
    inside.distance = -0.25;
    inside.inside = true;
    inside.winding = 0.75;
    EXPECT_EQ(write_points_response(s, engine::PointQuery::signed_distance, {inside, {}}),
              R"({"query":"signed_distance","results":[{"distance":-0.25},{"distance":null}]})");
    EXPECT_EQ(write_points_response(s, engine::PointQuery::occupancy, {inside}),
              R"({"query":"occupancy","results":[{"inside":true,"winding":0.75}]})");
}

std::string float_records(const std::vector<float>& v) {
    std::string out(v.size() * sizeof(float), '\0');
    std::memcpy(out.data(), v.data(), out.size());
    return out;
}

TEST(PointsCodec, DecodesAndRefusesBadRecords) {
    std::vector<engine::Vec3d> pts;
    decode_points(float_records({1, 2, 3, 4, 5, 6}), Dtype::float32, 10, pts);
    ASSERT_EQ(pts.size(), 2u);
    EXPECT_EQ(pts[1], (engine::Vec3d{4, 5, 6}));
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    for (float bad : {nan, inf, -inf}) {
        try {
            decode_points(float_records({1, 2, 3, 4, 5, 6, 7, bad, 9}), Dtype::float32, 10, pts);
            ADD_FAILURE() << "accepted " << bad;
        } catch (const ApiError& e) {
            EXPECT_EQ(e.code, ErrorCode::invalid_request);
            EXPECT_EQ(e.path, "/points/2");
        }
    }
    EXPECT_THROW(decode_points(std::string(13, '\0'), Dtype::float32, 10, pts), ApiError);
    try {
        decode_points(std::string(48, '\0'), Dtype::float64, 1, pts);
        ADD_FAILURE();
    } catch (const ApiError& e) {
        EXPECT_EQ(e.code, ErrorCode::too_large);
    }
}

TEST(PointsCodec, EncodesEachQuery) {
    engine::PointAnswer found;
    found.hit.point = {1, 2, 3};
    found.hit.distance = 0.5;
    found.hit.object = 4;
    found.hit.primitive = 9;
    found.hit.u = 0.25;
    found.hit.v = 0.5;
    found.distance = -0.5;
    found.winding = 1;
    const std::vector<engine::PointAnswer> a = {found, engine::PointAnswer{}};
    std::string out;
    encode_point_answers(a, engine::PointQuery::closest, Dtype::float32, out);
    ASSERT_EQ(out.size(), 64u);
    float f[8];
    std::uint32_t ids[2];
    std::memcpy(f, out.data(), 16);
    std::memcpy(ids, out.data() + 16, 8);
    std::memcpy(f + 4, out.data() + 24, 8);
    EXPECT_EQ(f[0], 1.0f);
    EXPECT_EQ(f[3], 0.5f);
    EXPECT_EQ(ids[0], 4u);
    EXPECT_EQ(ids[1], 9u);
    EXPECT_EQ(f[5], 0.5f);
    std::memcpy(f, out.data() + 32, 16);
    std::memcpy(ids, out.data() + 48, 8);
    EXPECT_EQ(f[3], std::numeric_limits<float>::infinity());
    EXPECT_EQ(ids[0], engine::kInvalidId);
    encode_point_answers(a, engine::PointQuery::closest, Dtype::float64, out);
    EXPECT_EQ(out.size(), 112u);
    encode_point_answers(a, engine::PointQuery::signed_distance, Dtype::float64, out);
    ASSERT_EQ(out.size(), 16u);
    double d[2];
    std::memcpy(d, out.data(), 16);
    EXPECT_EQ(d[0], -0.5);
    EXPECT_EQ(d[1], engine::kInfinity);
    encode_point_answers(a, engine::PointQuery::occupancy, Dtype::float32, out);
    ASSERT_EQ(out.size(), 8u);
    std::memcpy(f, out.data(), 8);
    EXPECT_EQ(f[0], 1.0f);
    EXPECT_EQ(f[1], 0.0f);
}

TEST(TopologyDoc, JsonRoundTrip) {
    TopologyEntry e;
    e.object = 3;
    e.name = "bunny";
    e.topology.vertices = 34834;
    e.topology.triangles = 69451;
    e.topology.boundary_edges = 223;
    e.topology.boundary_loops = 5;
    e.topology.components = 1;
    e.topology.euler_characteristic = -3;
    e.topology.refused_triangles = 2;
    e.topology.half_edge = false;
    std::string text;
    JsonWriter w(text);
    write_topology(w, {e});
    EXPECT_EQ(text,
              R"([{"object":3,"name":"bunny","vertices":34834,"triangles":69451,"closed":false,)"
              R"("boundary_edges":223,"boundary_loops":5,"non_manifold_edges":0,)"
              R"("non_manifold_vertices":0,"components":1,"euler_characteristic":-3,)"
              R"("consistently_oriented":true,"degenerate_triangles":0,"refused_triangles":2,)"
              R"("half_edge":false,"sign":"winding"}])");
    const auto back = topology_from_json(topology_to_json({e}));
    ASSERT_EQ(back.size(), 1u);
    EXPECT_EQ(back[0].name, "bunny");
    EXPECT_EQ(back[0].topology.euler_characteristic, -3);
    EXPECT_EQ(back[0].topology.boundary_loops, 5u);
    EXPECT_FALSE(back[0].topology.half_edge);
    EXPECT_EQ(back[0].topology.sign, engine::SignMethod::winding);
}

}  // namespace
}  // namespace raycastd::server
