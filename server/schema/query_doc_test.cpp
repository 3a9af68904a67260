#include "server/schema/query_doc.h"

#include <gtest/gtest.h>

#include "server/schema/scene_doc.h"

namespace raycastd::server {
namespace {

ApiError request_error(const std::string& text, std::size_t max_rays = 100) {
    try {
        parse_intersect_request(Json::parse(text), "", max_rays);
    } catch (const ApiError& e) {
        return e;
    }
    ADD_FAILURE() << "no error for " << text;
    return ApiError(ErrorCode::internal, "");
}

TEST(QueryDoc, ParsesRaysAndOptions) {
    IntersectRequest r =
        parse_intersect_request(Json::parse(R"({"rays": [{"origin":[0,0,0],"direction":[0,0,1]},
                                 {"origin":[1,2,3],"direction":[0,2,0],"tmin":0.5,"tmax":9}],
                        "mode":"all","precision":"exact","fields":["t","object"]})"),
                                "", 100);
    ASSERT_EQ(r.rays.size(), 2u);
    EXPECT_EQ(r.rays[1].tmin, 0.5);
    EXPECT_EQ(r.rays[1].tmax, 9.0);
    EXPECT_EQ(r.rays[0].tmax, engine::kInfinity);
    EXPECT_EQ(r.options.mode, engine::Mode::all);
    EXPECT_EQ(r.options.precision, engine::Precision::exact);
    EXPECT_TRUE(r.fields.t);
    EXPECT_FALSE(r.fields.point);
    EXPECT_FALSE(r.options.want_normal);
}

TEST(QueryDoc, RayErrorsNameTheIndex) {
    ApiError e = request_error(R"({"rays": [{"origin":[0,0,0],"direction":[0,0,1]},
                                             {"origin":[0,0,0],"direction":[0,0,0]}]})");
    EXPECT_EQ(e.code, ErrorCode::invalid_ray);
    EXPECT_EQ(e.path, "/rays/1/direction");
    EXPECT_NE(std::string(e.what()).find("ray 1"), std::string::npos);
    EXPECT_EQ(
        request_error(R"({"rays": [{"origin":[0,0,0],"direction":[0,0,1],"tmin":2,"tmax":1}]})")
            .code,
        ErrorCode::invalid_ray);
    EXPECT_EQ(request_error(R"({"rays": [{"direction":[0,0,1]}]})").path, "/rays/0/origin");
    EXPECT_EQ(request_error(R"({"rays": [], "mode": "first"})").path, "/mode");
    EXPECT_EQ(request_error(R"({"rays": [], "precision": "double"})").code,
              ErrorCode::invalid_request);
    EXPECT_EQ(request_error(R"({"rays": [], "fields": ["colour"]})").path, "/fields/0");
    EXPECT_EQ(request_error(R"({"rays": [{"origin":[0,0,0],"direction":[0,0,1]},
                                         {"origin":[0,0,0],"direction":[0,0,1]}]})",
                            1)
                  .code,
              ErrorCode::too_large);
}

TEST(QueryDoc, ResponseShapes) {
    auto scene = std::make_shared<engine::Scene>(
        parse_scene_doc(Json::parse(R"({"objects":[{"type":"sphere","center":[0,0,10],"radius":2},
                                  {"type":"sphere","center":[0,3,8],"radius":2},
                                  {"type":"sphere","center":[0,1,9],"radius":2}]})"),
                        "", {}));
    auto engine = *engine::QueryEngine::build(scene);
    IntersectRequest req = parse_intersect_request(
        Json::parse(
            R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]},{"origin":[0,0,0],"direction":[0,0,-1]}],
                        "fields":["t","object","name"]})"),
        "", 10);
    std::string out =
        write_intersect_response(*engine, req, engine->intersect(req.rays, req.options));
    EXPECT_EQ(
        out,
        R"({"precision":"exact","mode":"closest","hits":[{"hit":true,"t":7.267949192431123,"object":2,"name":"sphere 3"},{"hit":false}]})");
    Json full = Json::parse(write_intersect_response(
        *engine,
        parse_intersect_request(Json::parse(R"({"rays":[{"origin":[0,0,0],"direction":[0,0,1]}]})"),
                                "", 10),
        engine->intersect(req.rays, req.options)));
    const Json& h = full.at("hits").at(0);
    for (const char* k : {"t", "t_err", "point", "normal", "front_face", "object", "name",
                          "primitive", "barycentric"}) {
        EXPECT_TRUE(h.contains(k)) << k;
    }
    EXPECT_EQ(h.at("point").at(2).get<double>(), 7.267949192431123);
}

}  // namespace
}  // namespace raycastd::server
