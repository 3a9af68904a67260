// POST/GET /v1/scenes, GET/DELETE /v1/scenes/{id} (intersect: server/intersect/routes.cpp).

#include "server/app.h"
#include "server/model_source.h"
#include "server/scene_registry.h"
#include "server/schema/json_writer.h"
#include "server/schema/scene_doc.h"

namespace raycastd::server {

namespace {

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
    w.raw(",\"camera\":");
    if (i.camera) {
        w.raw("{\"position\":").vec(i.camera->position);
        w.raw(",\"look_at\":").vec(i.camera->look_at);
        w.raw(",\"up\":").vec(i.camera->up);
        w.raw(",\"fov_y_deg\":").number(i.camera->fov_y_deg).ch('}');
    } else {
        w.raw("null");
    }
    w.raw(",\"default_view\":").string(default_view_name(i.default_view));
    w.raw(",\"memory_bytes\":").integer(i.memory_bytes);
    w.raw(",\"topology\":");
    write_topology(w, i.topology);
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
    // Writes: the token is checked before the body is read (App::on_post).
    app.on_post(
        "/v1/scenes",
        [&app](const httplib::Request& req, httplib::Response& res) {
            app.handle(req, res, Work::heavy, [&] {
                SceneSource src{classify_scene_body(req.body, req.get_header_value("Content-Type")),
                                req.body};
                SceneRegistry::Added added =
                    app.registry().add(src, app.models().scene_root_files());
                send_json(res, info_body(added.info), added.created ? 201 : 200);
                res.set_header("Location", "/v1/scenes/" + added.info.id);
            });
        },
        Access::write_token);
    app.on_get("/v1/scenes", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, Work::light, [&] {
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
    app.on_get(R"(/v1/scenes/([A-Za-z0-9_]+))",
               [&app](const httplib::Request& req, httplib::Response& res) {
                   app.handle(req, res, Work::light, [&] {
                       auto info = app.registry().info(req.matches[1]);
                       if (!info)
                           throw App::scene_not_found(req.matches[1]);
                       send_json(res, info_body(*info));
                   });
               });
    app.on_delete(R"(/v1/scenes/([A-Za-z0-9_]+))",
                  [&app](const httplib::Request& req, httplib::Response& res) {
                      app.handle(req, res, Work::light, [&] {
                          const std::string id = req.matches[1];
                          if (!app.registry().remove(id))
                              throw App::scene_not_found(id);
                          send_json(res, "{\"id\":\"" + id + "\",\"deleted\":true}");
                      });
                  },
                  Access::write_token);
}

}  // namespace raycastd::server
