// POST /v1/scenes/{id}/render, the async jobs and POST /v1/scenes/{id}/trace against the real
// raycastd binary.

#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <stb_image.h>

#include "tests/support/server_process.h"

namespace raycastd {
namespace {

using Json = nlohmann::json;
using namespace std::chrono_literals;

std::string read_file(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

std::string scene_file(const std::string& name) {
    return read_file(RAYCASTD_SOURCE_DIR "/tests/golden/scenes/" + name + ".json");
}

/// Parses "primary=N, shadow=N, reflected=N, refracted=N" (in that order, nothing else) into
/// its counts; empty when the header has another shape. (No std::regex: GCC 12 warns inside it
/// under the sanitizers.)
std::map<std::string, long long> parse_rays(const std::string& header) {
    std::map<std::string, long long> out;
    std::string rebuilt;
    std::istringstream in(header);
    std::string item;
    while (std::getline(in, item, ',')) {
        if (!item.empty() && item[0] == ' ')
            item.erase(0, 1);
        const auto eq = item.find('=');
        if (eq == std::string::npos || eq + 1 == item.size())
            return {};
        const std::string digits = item.substr(eq + 1);
        if (digits.find_first_not_of("0123456789") != std::string::npos)
            return {};
        out[item.substr(0, eq)] = std::stoll(digits);
        rebuilt += (rebuilt.empty() ? "" : ", ") + item;
    }
    if (rebuilt != header || out.size() != 4 || !out.count("primary") || !out.count("shadow") ||
        !out.count("reflected") || !out.count("refracted") || header.find("primary=") != 0 ||
        header.find("shadow=") > header.find("reflected=") ||
        header.find("reflected=") > header.find("refracted=")) {
        return {};
    }
    return out;
}

class RenderApi : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        server_ = new testing::ServerProcess({"--max-pixels", "4000000"});
    }
    static void TearDownTestSuite() {
        delete server_;
        server_ = nullptr;
    }
    static std::string add_scene(const std::string& body) {
        auto res = server_->client()->Post("/v1/scenes", body, "application/json");
        if (!res || res->status >= 300)
            return "";
        return Json::parse(res->body).at("id");
    }
    static httplib::Result render(const std::string& id, const Json& body) {
        return server_->client()->Post("/v1/scenes/" + id + "/render", body.dump(),
                                       "application/json");
    }
    static testing::ServerProcess* server_;
};
testing::ServerProcess* RenderApi::server_ = nullptr;

TEST_F(RenderApi, PngWithTimingAndRayCounts) {
    const std::string id = add_scene(scene_file("tutorial_like"));
    ASSERT_FALSE(id.empty());
    auto res = render(id, {{"width", 64}, {"height", 48}, {"spp", 2}});
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << res->body;
    EXPECT_EQ(res->get_header_value("Content-Type"), "image/png");
    EXPECT_GE(std::stod(res->get_header_value("X-Render-Ms")), 0.0);
    // "trace=T, encode=E": T is X-Render-Ms itself, E the PNG encode after it.
    double trace = -1, encode = -1;
    ASSERT_EQ(std::sscanf(res->get_header_value("X-Render-Breakdown").c_str(),
                          "trace=%lf, encode=%lf", &trace, &encode),
              2)
        << res->get_header_value("X-Render-Breakdown");
    EXPECT_DOUBLE_EQ(trace, std::stod(res->get_header_value("X-Render-Ms")));
    EXPECT_GE(encode, 0.0);
    const std::string rays = res->get_header_value("X-Rays");
    const auto n = parse_rays(rays);
    ASSERT_EQ(n.size(), 4u) << rays;
    EXPECT_EQ(n.at("primary"), 64 * 48 * 2);
    EXPECT_GT(n.at("shadow"), 0);
    EXPECT_GT(n.at("reflected"), 0);
    EXPECT_GT(n.at("refracted"), 0);
    int w = 0, h = 0, c = 0;
    unsigned char* px =
        stbi_load_from_memory(reinterpret_cast<const unsigned char*>(res->body.data()),
                              static_cast<int>(res->body.size()), &w, &h, &c, 3);
    ASSERT_NE(px, nullptr);
    stbi_image_free(px);
    EXPECT_EQ(w, 64);
    EXPECT_EQ(h, 48);
}

TEST_F(RenderApi, EmptyBodyRendersTheDefaults) {
    const std::string id = add_scene(scene_file("spheres"));
    auto res = server_->client()->Post("/v1/scenes/" + id + "/render", "", "application/json");
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << res->body;
    EXPECT_EQ(parse_rays(res->get_header_value("X-Rays")).at("primary"), 640 * 480);
    // A preview defaults to fast (docs/rendering.md). Asked for refined, a scene this small is
    // answered by the exact path, as its queries are (API.md), and the header says so.
    EXPECT_EQ(res->get_header_value("X-Precision"), "fast");
    auto refined = render(id, {{"width", 8}, {"height", 8}, {"precision", "refined"}});
    ASSERT_TRUE(refined);
    EXPECT_EQ(refined->get_header_value("X-Precision"), "exact");
}

TEST_F(RenderApi, SkippingIsVisibleInXRays) {
    // No lights: the headlight (lighting auto), whose camera hits trace no shadow rays; matte
    // materials: no secondary rays.
    const std::string dark =
        add_scene(R"({"objects": [{"type": "sphere", "center": [0,0,10], "radius": 2}]})");
    auto res = render(dark, {{"width", 32}, {"height", 32}});
    ASSERT_EQ(res->status, 200);
    auto n = parse_rays(res->get_header_value("X-Rays"));
    EXPECT_EQ(n.at("shadow"), 0);
    EXPECT_EQ(n.at("reflected") + n.at("refracted"), 0);
    const std::string matte = add_scene(scene_file("spheres"));
    res = render(matte, {{"width", 32}, {"height", 32}});
    n = parse_rays(res->get_header_value("X-Rays"));
    EXPECT_GT(n.at("shadow"), 0);
    EXPECT_EQ(n.at("reflected"), 0);
    EXPECT_EQ(n.at("refracted"), 0);
}

TEST_F(RenderApi, LightingAutoGivesABareSceneTheHeadlight) {
    // No lights, a mirror sphere beside a matte one: auto = headlight. Camera hits trace no
    // shadow ray for it, the hits of reflected rays do (docs/rendering.md).
    const std::string bare = add_scene(R"({"objects": [
        {"type": "sphere", "center": [-1.2,0,10], "radius": 1, "material": "mirror"},
        {"type": "sphere", "center": [1.2,0,10], "radius": 1}],
        "materials": {"mirror": {"reflectivity": 0.8}}})");
    ASSERT_FALSE(bare.empty());
    const Json size{{"width", 48}, {"height", 32}};
    auto deflt = render(bare, size);
    ASSERT_EQ(deflt->status, 200) << deflt->body;
    const auto n = parse_rays(deflt->get_header_value("X-Rays"));
    EXPECT_GT(n.at("reflected"), 0);
    EXPECT_GT(n.at("shadow"), 0);
    EXPECT_LE(n.at("shadow"),
              n.at("reflected"));  // one per secondary hit facing the light, at most
    Json head = size;
    head["lighting"] = "headlight";
    auto asked = render(bare, head);
    EXPECT_EQ(asked->get_header_value("X-Rays"), deflt->get_header_value("X-Rays"));
    EXPECT_EQ(asked->body, deflt->body);
    // The document's own lights: none, so ambient 1.0 only and no shadow rays at all.
    Json scene = size;
    scene["lighting"] = "scene";
    auto flat = render(bare, scene);
    ASSERT_EQ(flat->status, 200);
    EXPECT_EQ(parse_rays(flat->get_header_value("X-Rays")).at("shadow"), 0);
    EXPECT_NE(flat->body, deflt->body);
    // A lit document keeps its lights under auto; headlight replaces them.
    const std::string lit = add_scene(scene_file("spheres"));
    EXPECT_GT(parse_rays(render(lit, size)->get_header_value("X-Rays")).at("shadow"), 0);
    EXPECT_EQ(parse_rays(render(lit, head)->get_header_value("X-Rays")).at("shadow"), 0);
    auto bad = render(bare, {{"lighting", "sun"}});
    EXPECT_EQ(bad->status, 400);
    EXPECT_EQ(Json::parse(bad->body).at("error").at("code"), "invalid_request");
    EXPECT_EQ(Json::parse(bad->body).at("error").at("path"), "/lighting");
}

TEST_F(RenderApi, OtherFormatsAndModes) {
    const std::string id = add_scene(scene_file("spheres"));
    auto ppm = render(id, {{"width", 8}, {"height", 4}, {"format", "ppm"}});
    ASSERT_EQ(ppm->status, 200);
    EXPECT_EQ(ppm->body.rfind("P6\n8 4\n255\n", 0), 0u);
    auto pfm = render(id, {{"width", 8}, {"height", 4}, {"format", "pfm"}});
    EXPECT_EQ(pfm->body.rfind("PF\n8 4\n", 0), 0u);
    auto exr = render(id, {{"width", 8}, {"height", 4}, {"format", "exr"}});
    ASSERT_EQ(exr->status, 200);
    EXPECT_EQ(exr->get_header_value("Content-Type"), "image/x-exr");
    EXPECT_EQ(exr->body.substr(0, 4), std::string("\x76\x2f\x31\x01", 4));
    for (const char* mode : {"normal", "depth", "object_id", "barycentric"}) {
        auto res = render(id, {{"width", 16}, {"height", 12}, {"shading", mode}});
        ASSERT_EQ(res->status, 200) << mode << ": " << res->body;
        EXPECT_EQ(parse_rays(res->get_header_value("X-Rays")).at("shadow"), 0) << mode;
    }
}

TEST_F(RenderApi, Errors) {
    const std::string id = add_scene(scene_file("spheres"));
    auto missing = render("sc_nope", Json::object());
    EXPECT_EQ(missing->status, 404);
    EXPECT_EQ(Json::parse(missing->body).at("error").at("code"), "scene_not_found");
    auto big = render(id, {{"width", 2000}, {"height", 1000}, {"spp", 4}});
    EXPECT_EQ(big->status, 413);
    EXPECT_EQ(Json::parse(big->body).at("error").at("code"), "too_large");
    auto fmt = render(id, {{"format", "jpeg"}});
    EXPECT_EQ(fmt->status, 400);
    EXPECT_EQ(Json::parse(fmt->body).at("error").at("code"), "unsupported_format");
    auto mode = render(id, {{"shading", "toon"}});
    EXPECT_EQ(Json::parse(mode->body).at("error").at("path"), "/shading");
    auto bad = server_->client()->Post("/v1/scenes/" + id + "/render", "{", "application/json");
    EXPECT_EQ(Json::parse(bad->body).at("error").at("code"), "bad_json");
    // An unknown job is job_not_found (docs/api.md), not the not_found of an unknown endpoint.
    auto job = server_->client()->Get("/v1/jobs/jb_0000000000000000");
    EXPECT_EQ(job->status, 404);
    EXPECT_EQ(Json::parse(job->body).at("error").at("code"), "job_not_found");
    auto image = server_->client()->Get("/v1/jobs/jb_0000000000000000/image");
    EXPECT_EQ(image->status, 404);
    EXPECT_EQ(Json::parse(image->body).at("error").at("code"), "job_not_found");
    auto cancel = server_->client()->Delete("/v1/jobs/jb_0000000000000000");
    EXPECT_EQ(cancel->status, 404);
    EXPECT_EQ(Json::parse(cancel->body).at("error").at("code"), "job_not_found");
}

TEST_F(RenderApi, AsyncJobGivesTheSameImage) {
    const std::string id = add_scene(scene_file("glass_sphere"));
    const Json opts = {{"width", 96}, {"height", 64}, {"spp", 2}};
    auto sync = render(id, opts);
    ASSERT_EQ(sync->status, 200);
    Json async_opts = opts;
    async_opts["async"] = true;
    auto sub = render(id, async_opts);
    ASSERT_EQ(sub->status, 202) << sub->body;
    const std::string job = Json::parse(sub->body).at("job");
    EXPECT_EQ(job.rfind("jb_", 0), 0u);
    EXPECT_EQ(sub->get_header_value("Location"), "/v1/jobs/" + job);
    auto c = server_->client();
    Json status;
    double last = 0;
    for (int i = 0; i < 500; ++i) {
        auto r = c->Get("/v1/jobs/" + job);
        ASSERT_EQ(r->status, 200);
        status = Json::parse(r->body);
        EXPECT_GE(status.at("progress").get<double>(), last);
        last = status.at("progress");
        if (status.at("state") == "done")
            break;
        std::this_thread::sleep_for(10ms);
    }
    ASSERT_EQ(status.at("state"), "done") << status;
    EXPECT_EQ(status.at("progress"), 1.0);
    EXPECT_EQ(status.at("eta_s"), 0.0);
    EXPECT_EQ(status.at("tiles_done"), status.at("tiles_total"));
    auto img = c->Get("/v1/jobs/" + job + "/image");
    ASSERT_EQ(img->status, 200);
    EXPECT_EQ(img->body, sync->body);  // the renderer is deterministic
    EXPECT_EQ(img->get_header_value("X-Rays"), sync->get_header_value("X-Rays"));
    // DELETE of a finished job forgets it.
    auto del = c->Delete("/v1/jobs/" + job);
    EXPECT_EQ(Json::parse(del->body).at("deleted"), true);
    EXPECT_EQ(c->Get("/v1/jobs/" + job)->status, 404);
}

TEST_F(RenderApi, DeleteCancelsARunningJob) {
    const std::string id = add_scene(scene_file("tutorial_like"));
    auto sub = render(id, {{"width", 1000}, {"height", 1000}, {"spp", 4}, {"async", true}});
    ASSERT_EQ(sub->status, 202) << sub->body;
    const std::string job = Json::parse(sub->body).at("job");
    auto c = server_->client();
    // The image is not there yet: 202 with the job's status.
    auto early = c->Get("/v1/jobs/" + job + "/image");
    EXPECT_EQ(early->status, 202);
    EXPECT_NE(Json::parse(early->body).at("state"), "done");
    auto del = c->Delete("/v1/jobs/" + job);
    ASSERT_EQ(del->status, 200);
    EXPECT_EQ(Json::parse(del->body).at("state"), "cancelled");
    Json status;
    for (int i = 0; i < 300; ++i) {
        status = Json::parse(c->Get("/v1/jobs/" + job)->body);
        if (status.at("state") == "cancelled")
            break;
        std::this_thread::sleep_for(10ms);
    }
    EXPECT_EQ(status.at("state"), "cancelled");
    EXPECT_LT(status.at("progress").get<double>(), 1.0);
    auto img = c->Get("/v1/jobs/" + job + "/image");
    EXPECT_EQ(img->status, 404);
    EXPECT_EQ(Json::parse(img->body).at("error").at("code"), "job_not_found");
}

TEST(RenderApiBusy, JobQueueOverTheLimitIs503) {
    testing::ServerProcess server({"--max-concurrent", "1"});
    auto c = server.client();
    auto reg = c->Post("/v1/scenes", scene_file("tutorial_like"), "application/json");
    const std::string id = Json::parse(reg->body).at("id");
    const Json slow = {{"width", 1000}, {"height", 1000}, {"spp", 4}, {"async", true}};
    auto first = c->Post("/v1/scenes/" + id + "/render", slow.dump(), "application/json");
    ASSERT_EQ(first->status, 202);
    auto second = c->Post("/v1/scenes/" + id + "/render", slow.dump(), "application/json");
    EXPECT_EQ(second->status, 503);
    EXPECT_EQ(Json::parse(second->body).at("error").at("code"), "busy");
    c->Delete("/v1/jobs/" + Json::parse(first->body).at("job").get<std::string>());
}

// The tutorial's Question 2 over HTTP, with the scene of tests/golden/scenes/tutorial_q2.json.
// Its tree, derived by hand (engine/shade/whitted_test.cpp has the same scene, step by step):
// eye (0,0,0), ray +z, point light L = (0,3,0) (lights[1]).
//   I1 (0,0,8)   glass entry.  Shadow ray to L clear:            full Phong.
//   I2 (0,0,−5)  mirror, reached by I1's reflection (back along −z). Clear: full Phong.
//   I3 (0,−5,−5) ball, reached by I2's reflection (along −y). Clear:   full Phong.
//   I4 (0,0,12)  glass exit, reached by I1's refraction (straight through at normal incidence).
//                The shadow ray runs inside glass: blocked by glass.  Ambient only.
//   I5 (0,0,18)  back, reached by I4's refraction. Its shadow ray passes through glass for
//                s ∈ (0.350, 0.515): blocked by glass.               Ambient only.
TEST_F(RenderApi, TraceTutorialQuestion2) {
    const std::string id = add_scene(scene_file("tutorial_q2"));
    ASSERT_FALSE(id.empty());
    auto res = server_->client()->Post(
        "/v1/scenes/" + id + "/trace",
        R"({"ray": {"origin": [0,0,0], "direction": [0,0,1]}, "max_depth": 5})",
        "application/json");
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << res->body;
    const Json j = Json::parse(res->body);
    EXPECT_EQ(j.at("summary"), Json::parse(R"({"points": 5, "full_phong": ["I1","I2","I3"],
                                               "ambient_only": ["I4","I5"]})"));
    const Json& i1 = j.at("tree");
    EXPECT_EQ(i1.at("label"), "I1");
    EXPECT_EQ(i1.at("name"), "glass");
    EXPECT_EQ(i1.at("t"), 8.0);
    EXPECT_EQ(i1.at("shadow_rays"),
              Json::parse(R"([{"light": 1, "blocked_by": null, "facing": true}])"));
    const Json& i2 = i1.at("reflected");
    EXPECT_EQ(i2.at("label"), "I2");
    EXPECT_EQ(i2.at("name"), "mirror");
    EXPECT_EQ(i2.at("reflected").at("label"), "I3");
    EXPECT_EQ(i2.at("reflected").at("name"), "ball");
    const Json& i4 = i1.at("refracted");
    EXPECT_EQ(i4.at("label"), "I4");
    EXPECT_EQ(i4.at("terms"), Json::parse(R"(["ambient"])"));
    EXPECT_EQ(i4.at("shadow_rays").at(0).at("blocked_by"), "glass");
    EXPECT_TRUE(i4.at("reflected").is_null());  // internal reflection is not traced
    const Json& i5 = i4.at("refracted");
    EXPECT_EQ(i5.at("label"), "I5");
    EXPECT_EQ(i5.at("name"), "back");
    EXPECT_EQ(i5.at("shadow_rays").at(0).at("blocked_by"), "glass");
    EXPECT_EQ(i5.at("terms"), Json::parse(R"(["ambient"])"));
}

TEST_F(RenderApi, TraceErrorsAndMiss) {
    const std::string id = add_scene(scene_file("tutorial_q2"));
    auto c = server_->client();
    auto miss =
        c->Post("/v1/scenes/" + id + "/trace",
                R"({"ray": {"origin": [0,0,0], "direction": [1,0,0]}})", "application/json");
    ASSERT_EQ(miss->status, 200);
    EXPECT_TRUE(Json::parse(miss->body).at("tree").is_null());
    auto zero =
        c->Post("/v1/scenes/" + id + "/trace",
                R"({"ray": {"origin": [0,0,0], "direction": [0,0,0]}})", "application/json");
    EXPECT_EQ(zero->status, 400);
    EXPECT_EQ(Json::parse(zero->body).at("error").at("code"), "invalid_ray");
    auto none =
        c->Post("/v1/scenes/sc_nope/trace", R"({"ray": {"origin": [0,0,0], "direction": [0,0,1]}})",
                "application/json");
    EXPECT_EQ(none->status, 404);
}

}  // namespace
}  // namespace raycastd
