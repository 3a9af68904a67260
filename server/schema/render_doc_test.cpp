#include "server/schema/render_doc.h"

#include <memory>

#include <gtest/gtest.h>

#include "engine/testing/scenes.h"

namespace raycastd::server {
namespace {

constexpr std::size_t kMaxPixels = 16u << 20;

ApiError error_of(const std::function<void()>& f) {
    try {
        f();
    } catch (const ApiError& e) {
        return e;
    }
    ADD_FAILURE() << "no ApiError thrown";
    return ApiError(ErrorCode::internal, "none");
}

TEST(RenderDoc, DefaultsFromAnEmptyBody) {
    const RenderRequest r = parse_render_request(Json(), kMaxPixels);
    EXPECT_EQ(r.options.width, 640);
    EXPECT_EQ(r.options.height, 480);
    EXPECT_EQ(r.options.spp, 1);
    EXPECT_EQ(r.options.whitted.max_depth, 5);
    EXPECT_EQ(r.options.whitted.precision, engine::Precision::fast);  // previews: fast
    EXPECT_EQ(r.options.shading, engine::ShadingMode::phong);
    EXPECT_EQ(r.options.lighting, engine::Lighting::automatic);
    EXPECT_EQ(r.format, engine::ImageFormat::png);
    EXPECT_FALSE(r.async);
    EXPECT_FALSE(r.options.camera);
    EXPECT_EQ(parse_render_request(Json::object(), kMaxPixels).options.width, 640);
}

TEST(RenderDoc, ReadsEveryField) {
    const Json body = Json::parse(R"({"camera": {"position": [0,0,-5], "look_at": [0,0,0],
        "up": [0,1,0], "fov_y_deg": 30}, "width": 64, "height": 32, "spp": 4, "max_depth": 3,
        "shading": "object_id", "format": "exr", "precision": "fast", "async": true,
        "background": [0.1, 0.2, 0.3], "lighting": "headlight"})");
    const RenderRequest r = parse_render_request(body, kMaxPixels);
    ASSERT_TRUE(r.options.camera);
    EXPECT_EQ(r.options.camera->position, engine::Vec3d(0, 0, -5));
    EXPECT_EQ(r.options.camera->fov_y_deg, 30.0);
    EXPECT_EQ(r.options.width, 64);
    EXPECT_EQ(r.options.height, 32);
    EXPECT_EQ(r.options.spp, 4);
    EXPECT_EQ(r.options.whitted.max_depth, 3);
    EXPECT_EQ(r.options.whitted.precision, engine::Precision::fast);
    EXPECT_EQ(r.options.whitted.background, engine::Vec3d(0.1, 0.2, 0.3));
    EXPECT_EQ(r.options.shading, engine::ShadingMode::object_id);
    EXPECT_EQ(r.format, engine::ImageFormat::exr);
    EXPECT_TRUE(r.async);
    EXPECT_EQ(r.options.lighting, engine::Lighting::headlight);
    for (const auto& [name, lighting] :
         {std::pair{"scene", engine::Lighting::scene}, {"auto", engine::Lighting::automatic}}) {
        const Json b{{"lighting", name}};
        EXPECT_EQ(parse_render_request(b, kMaxPixels).options.lighting, lighting) << name;
    }
}

TEST(RenderDoc, SamplingIsUniformUnlessAskedAdaptive) {
    EXPECT_FALSE(parse_render_request(Json::object(), kMaxPixels).options.adaptive);
    EXPECT_FALSE(parse_render_request(Json{{"sampling", "uniform"}}, kMaxPixels).options.adaptive);
    EXPECT_TRUE(parse_render_request(Json{{"sampling", "adaptive"}}, kMaxPixels).options.adaptive);
}

TEST(RenderDoc, ErrorsNameTheField) {
    auto parse = [](const char* text) {
        return error_of([&] { parse_render_request(Json::parse(text), kMaxPixels); });
    };
    EXPECT_EQ(parse(R"({"width": 0})").path, "/width");
    EXPECT_EQ(parse(R"({"width": 1.5})").code, ErrorCode::invalid_request);
    EXPECT_EQ(parse(R"({"spp": "4"})").path, "/spp");
    EXPECT_EQ(parse(R"({"max_depth": 0})").path, "/max_depth");
    EXPECT_EQ(parse(R"({"shading": "toon"})").path, "/shading");
    const ApiError l = parse(R"({"lighting": "sun"})");
    EXPECT_EQ(l.code, ErrorCode::invalid_request);
    EXPECT_EQ(l.path, "/lighting");
    EXPECT_EQ(l.http_status(), 400);
    EXPECT_EQ(parse(R"({"lighting": 1})").path, "/lighting");
    const ApiError f = parse(R"({"format": "jpeg"})");
    EXPECT_EQ(f.code, ErrorCode::unsupported_format);
    EXPECT_EQ(f.http_status(), 400);
    EXPECT_EQ(parse(R"({"camera": {"position": [0,0,0], "look_at": [0,0,0]}})").path,
              "/camera/look_at");
    EXPECT_EQ(parse(R"({"camera": {"up": [0,0,1]}})").path, "/camera/up");
    // look_at − position must be finite; a tiny one is a direction like any other (its cross
    // product with up had underflowed, and it was refused as parallel).
    EXPECT_EQ(parse(R"({"camera": {"position": [-1e308,0,0], "look_at": [1e308,0,0]}})").path,
              "/camera/look_at");
    EXPECT_NO_THROW(parse_render_request(
        Json::parse(R"({"camera": {"position": [0,0,0], "look_at": [1e-300,0,1e-300]}})"),
        kMaxPixels));
    EXPECT_EQ(parse(R"({"async": 1})").path, "/async");
    EXPECT_EQ(parse(R"({"sampling": "stochastic"})").path, "/sampling");
    EXPECT_EQ(parse(R"({"sampling": true})").path, "/sampling");
    EXPECT_EQ(parse(R"([1])").code, ErrorCode::invalid_request);
    // A background is a linear colour: not negative, and finite in a float image.
    EXPECT_EQ(parse(R"({"background": [-0.1, 0, 0]})").path, "/background");
    EXPECT_EQ(parse(R"({"background": [0, 1e308, 0]})").path, "/background");
    EXPECT_EQ(parse_render_request(Json::parse(R"({"background": [0, 1e6, 2]})"), kMaxPixels)
                  .options.whitted.background,
              engine::Vec3d(0, 1e6, 2));
}

TEST(RenderDoc, PixelLimitCountsSamples) {
    const Json body = Json::parse(R"({"width": 100, "height": 100, "spp": 4})");
    EXPECT_NO_THROW(parse_render_request(body, 40000));
    const ApiError e = error_of([&] { parse_render_request(body, 39999); });
    EXPECT_EQ(e.code, ErrorCode::too_large);
    EXPECT_EQ(e.http_status(), 413);
}

TEST(RenderDoc, PixelLimitHoldsForTheDefaults) {
    // An empty body renders the defaults (640 × 480 at 1 spp): a smaller --max-pixels refuses
    // them too.
    EXPECT_NO_THROW(parse_render_request(Json(), 640 * 480));
    EXPECT_EQ(error_of([] { parse_render_request(Json(), 640 * 480 - 1); }).code,
              ErrorCode::too_large);
    EXPECT_EQ(error_of([] { parse_render_request(Json::object(), 1000); }).code,
              ErrorCode::too_large);
}

TEST(RenderDoc, TraceRequestAndRayErrors) {
    const TraceRequest t = parse_trace_request(
        Json::parse(R"({"ray": {"origin": [0,0,0], "direction": [0,0,1]}, "max_depth": 2})"));
    EXPECT_EQ(t.ray.direction, engine::Vec3d(0, 0, 1));
    EXPECT_EQ(t.options.max_depth, 2);
    EXPECT_EQ(error_of([] { parse_trace_request(Json::parse("{}")); }).code,
              ErrorCode::invalid_request);
    const ApiError zero = error_of([] {
        parse_trace_request(Json::parse(R"({"ray": {"origin": [0,0,0], "direction": [0,0,0]}})"));
    });
    EXPECT_EQ(zero.code, ErrorCode::invalid_ray);
    EXPECT_EQ(zero.path, "/ray/direction");
}

TEST(RenderDoc, TraceJsonShape) {
    engine::Scene s = engine::testing::tutorial_spheres();
    engine::Light l;
    l.type = engine::LightType::point;
    l.position = {0, 0, -10};
    s.lights = {l};
    auto engine = *engine::QueryEngine::build(std::make_shared<const engine::Scene>(s));
    const engine::RayTree tree = engine::Whitted(*engine, {}).tree({{0, 0, 0}, {0, 0, 1}}).value();
    const Json j = Json::parse(write_trace_json(engine->scene(), tree, engine::Precision::exact));
    const Json& n = j.at("tree");
    EXPECT_EQ(n.at("label"), "I1");
    EXPECT_EQ(n.at("name"), "sphere 3");
    EXPECT_NEAR(n.at("t").get<double>(), 7.267949192431123, 1e-12);
    EXPECT_EQ(n.at("shadow_rays"),
              Json::parse(R"([{"light": 0, "blocked_by": null, "facing": true}])"));
    EXPECT_EQ(n.at("terms"), Json::parse(R"(["ambient","diffuse","specular"])"));
    EXPECT_TRUE(n.at("reflected").is_null());
    EXPECT_TRUE(n.at("refracted").is_null());
    EXPECT_EQ(j.at("summary"),
              Json::parse(R"({"points": 1, "full_phong": ["I1"], "ambient_only": []})"));
    EXPECT_EQ(j.at("rays").at("shadow"), 1);
    const engine::RayTree miss = engine::Whitted(*engine, {}).tree({{0, 0, 0}, {1, 0, 0}}).value();
    const Json m = Json::parse(write_trace_json(engine->scene(), miss, engine::Precision::exact));
    EXPECT_TRUE(m.at("tree").is_null());
    EXPECT_EQ(m.at("summary").at("points"), 0);
}

TEST(RenderDoc, RaysHeader) {
    engine::RayCounts c;
    c.primary = 4;
    c.shadow = 3;
    c.reflected = 2;
    c.refracted = 1;
    EXPECT_EQ(rays_header(c), "primary=4, shadow=3, reflected=2, refracted=1");
}

}  // namespace
}  // namespace raycastd::server
