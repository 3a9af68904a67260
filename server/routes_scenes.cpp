// POST/GET/DELETE /v1/scenes[/{id}] and POST /v1/scenes/{id}/intersect.

#include <charconv>

#include "server/app.h"
#include "server/binary_stream.h"
#include "server/scene_registry.h"
#include "server/schema/json_writer.h"
#include "server/schema/ray_sax.h"

namespace raycastd::server {

namespace {

/// A StreamedBatch (server/binary_stream.h) for a binary closest/any request on a registered
/// scene that announces a valid batch of at least one chunk within the limits; nullptr
/// otherwise: that request reads its whole body first, and reports whatever is wrong with it
/// (an unknown scene, a bad parameter, a bad length) after reading it, as before.
std::shared_ptr<StreamedBatch> plan_streamed(App& app, const httplib::Request& req,
                                             const std::shared_ptr<Scratch>& scratch) {
    // The announced length must be the body's: not chunked, not compressed (cpp-httplib
    // inflates gzip/deflate/br bodies, whose Content-Length is then the compressed size).
    if (!is_binary(req) || !req.has_header("Content-Length") ||
        req.has_header("Transfer-Encoding") || req.has_header("Content-Encoding")) {
        return nullptr;
    }
    const std::string cl = req.get_header_value("Content-Length");
    std::size_t bytes = 0;
    const auto [end, ec] = std::from_chars(cl.data(), cl.data() + cl.size(), bytes);
    if (ec != std::errc() || end != cl.data() + cl.size())
        return nullptr;
    if (bytes > app.config().limits.max_body_bytes)
        return nullptr;
    try {
        const BinaryQuery q = parse_binary_query(req);
        if (q.options.mode != engine::Mode::closest && q.options.mode != engine::Mode::any)
            return nullptr;
        const std::size_t rays = ray_count(bytes, q.dtype, app.config().limits.max_rays);
        if (rays < StreamedBatch::kChunkRays)
            return nullptr;
        auto engine = app.registry().get(req.matches[1]);
        if (!engine)
            return nullptr;
        return std::make_shared<StreamedBatch>(std::move(engine), q.options, q.dtype, rays,
                                               scratch);
    } catch (const ApiError&) {
        return nullptr;
    }
}

std::string info_body(const SceneInfo& i) {
    std::string out;
    JsonWriter w(out);
    w.raw("{\"id\":").string(i.id);
    w.raw(",\"objects\":").integer(i.objects);
    w.raw(",\"triangles\":").integer(i.triangles);
    w.raw(",\"spheres\":").integer(i.spheres);
    w.raw(",\"bounds\":");
    if (i.bounds.empty()) {
        w.raw("null");
    } else {
        w.raw("{\"min\":").vec(i.bounds.lo).raw(",\"max\":").vec(i.bounds.hi).ch('}');
    }
    w.raw(",\"build_ms\":").number(i.build_ms);
    w.raw(",\"features\":{\"shadows\":").boolean(i.features.shadows);
    w.raw(",\"reflection\":").boolean(i.features.reflection);
    w.raw(",\"refraction\":").boolean(i.features.refraction);
    w.raw(",\"textures\":").boolean(i.features.textures).ch('}');
    w.raw(",\"memory_bytes\":").integer(i.memory_bytes);
    w.raw(",\"warnings\":[");
    for (std::size_t k = 0; k < i.warnings.size(); ++k) {
        if (k)
            w.ch(',');
        w.string(i.warnings[k]);
    }
    w.raw("]}");
    return out;
}

}  // namespace

void install_scene_routes(App& app) {
    auto& http = app.http();
    http.Post("/v1/scenes", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, true, [&] {
            SceneSource src{app.classify_scene_body(req), req.body};
            SceneRegistry::Added added = app.registry().add(src, app.scene_root_files());
            send_json(res, info_body(added.info), added.created ? 201 : 200);
            res.set_header("Location", "/v1/scenes/" + added.info.id);
        });
    });
    http.Get("/v1/scenes", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, false, [&] {
            std::string out = "{\"scenes\":[";
            bool first = true;
            for (const SceneInfo& i : app.registry().list()) {
                if (!first)
                    out += ',';
                first = false;
                out += info_body(i);
            }
            send_json(res, out + "]}");
        });
    });
    http.Get(R"(/v1/scenes/([A-Za-z0-9_]+))",
             [&app](const httplib::Request& req, httplib::Response& res) {
                 app.handle(req, res, false, [&] {
                     auto info = app.registry().info(req.matches[1]);
                     if (!info)
                         throw App::scene_not_found(req.matches[1]);
                     send_json(res, info_body(*info));
                 });
             });
    http.Delete(R"(/v1/scenes/([A-Za-z0-9_]+))",
                [&app](const httplib::Request& req, httplib::Response& res) {
                    app.handle(req, res, false, [&] {
                        const std::string id = req.matches[1];
                        if (!app.registry().remove(id))
                            throw App::scene_not_found(id);
                        send_json(res, "{\"id\":\"" + id + "\",\"deleted\":true}");
                    });
                });
    // The body is streamed into a pooled buffer and binary answers are written from another
    // (server/scratch.h): a 1M-ray batch moves 32-64 MB each way, and fresh buffers of that
    // size cost more in page faults than tracing the rays (PERFORMANCE.md).
    http.Post(R"(/v1/scenes/([A-Za-z0-9_]+)/intersect)",
              [&app](const httplib::Request& req, httplib::Response& res,
                     const httplib::ContentReader& read) {
                  app.handle(req, res, true, [&] {
                      auto scratch = acquire_scratch();
                      std::string& body = scratch->body;
                      body.clear();
                      auto stream = plan_streamed(app, req, scratch);
                      const std::size_t limit = app.config().limits.max_body_bytes;
                      bool over = false;
                      read([&](const char* data, std::size_t len) {
                          if (stream)
                              return stream->append(data, len);
                          if (body.size() + len > limit) {
                              over = true;
                              return false;
                          }
                          body.append(data, len);
                          return true;
                      });
                      if (over)
                          throw api_error("too_large", "request body is over the configured limit");
                      if (stream) {
                          stream->finish();
                          send_streamed_answer(std::move(stream), app.extend_work_slot(), res);
                          return;
                      }
                      auto engine = app.scene_or_404(req.matches[1]);
                      if (is_binary(req)) {
                          answer_binary_intersect(*engine, req, std::move(scratch),
                                                  app.config().limits.max_rays, res);
                          return;
                      }
                      if (body.empty())
                          throw api_error("bad_json", "empty body: a JSON document is required");
                      const std::size_t max_rays = app.config().limits.max_rays;
                      IntersectRequest& fast = scratch->parsed;
                      fast.rays.clear();  // keeps its capacity for the next request
                      fast.options = {};
                      fast.fields = {};
                      if (parse_intersect_request_fast(body, max_rays, fast)) {
                          answer_parsed_intersect(*engine, fast, scratch->result, res);
                          return;
                      }
                      Json doc;
                      try {
                          doc = Json::parse(body);
                      } catch (const Json::exception& e) {
                          throw api_error("bad_json",
                                          std::string("body is not valid JSON: ") + e.what());
                      }
                      answer_intersect(*engine, doc, "", app.config().limits.max_rays, res);
                  });
              });
}

}  // namespace raycastd::server
