// POST /v1/intersect (stateless) and, with the registry, POST /v1/scenes/{id}/intersect.

#include "engine/query/intersect.h"
#include "server/app.h"
#include "server/binary_stream.h"
#include "server/schema/binary_codec.h"
#include "server/schema/query_doc.h"
#include "server/schema/scene_doc.h"

namespace raycastd::server {

void answer_parsed_intersect(const engine::QueryEngine& engine, const IntersectRequest& req,
                             engine::QueryResult& result, httplib::Response& res) {
    engine.intersect(req.rays, req.options, result);
    send_json(res, write_intersect_response(engine.scene(), req, result));
}

void answer_intersect(const engine::QueryEngine& engine, const Json& body,
                      const std::string& prefix, std::size_t max_rays, httplib::Response& res) {
    const auto scratch = acquire_scratch();
    answer_parsed_intersect(engine, parse_intersect_request(body, prefix, max_rays),
                            scratch->result, res);
}

bool is_binary(const httplib::Request& req) {
    const std::string ct = req.get_header_value("Content-Type");
    return ct.rfind("application/octet-stream", 0) == 0;
}

BinaryQuery parse_binary_query(const httplib::Request& req) {
    BinaryQuery q;
    engine::QueryOptions& opt = q.options;
    const auto param = [&](const char* k) {
        return req.has_param(k) ? req.get_param_value(k) : std::string();
    };
    if (req.has_param("mode"))
        opt.mode = parse_mode(param("mode"), "mode");
    if (req.has_param("precision"))
        opt.precision = parse_precision(param("precision"), "precision");
    q.dtype = parse_dtype(param("dtype"));
    opt.want_normal = true;
    if (req.has_param("fields")) {
        // ?fields=t,object: normals are left out (zeros) unless asked for.
        const std::string f = param("fields");
        opt.want_normal = f.find("normal") != std::string::npos;
    }
    return q;
}

void send_binary_answer(const BinaryQuery& q, engine::Precision precision,
                        std::shared_ptr<Scratch> scratch, httplib::Response& res) {
    res.status = 200;
    res.set_header("X-Precision", engine::to_string(precision));
    res.set_header("X-Mode", engine::to_string(q.options.mode));
    // The provider keeps the scratch (and so `out`) until the response has been written.
    const std::size_t size = scratch->out.size();
    res.set_content_provider(size, "application/octet-stream",
                             [scratch = std::move(scratch)](std::size_t offset, std::size_t length,
                                                            httplib::DataSink& sink) {
                                 return sink.write(scratch->out.data() + offset, length);
                             });
}

void send_streamed_answer(std::shared_ptr<StreamedBatch> batch, std::shared_ptr<void> slot,
                          httplib::Response& res) {
    res.status = 200;
    res.set_header("X-Precision", engine::to_string(batch->precision()));
    res.set_header("X-Mode", engine::to_string(batch->mode()));
    const std::size_t size = batch->answer_bytes();
    // The provider keeps the batch (and its scratch) and the work slot until the answer has
    // been written; a chunk is handed over as soon as it is traced.
    res.set_content_provider(
        size, "application/octet-stream",
        [batch = std::move(batch), slot = std::move(slot)](std::size_t offset, std::size_t length,
                                                           httplib::DataSink& sink) {
            return batch->write_answer(
                offset, length, [&](const char* p, std::size_t n) { return sink.write(p, n); });
        });
}

void answer_binary_intersect(const engine::QueryEngine& engine, const httplib::Request& req,
                             std::shared_ptr<Scratch> scratch, std::size_t max_rays,
                             httplib::Response& res) {
    const BinaryQuery q = parse_binary_query(req);
    Scratch& s = *scratch;
    const engine::Mode mode = q.options.mode;
    if (mode == engine::Mode::closest || mode == engine::Mode::any) {
        // Records in, records out, a block at a time (intersect_records).
        const std::size_t n = ray_count(s.body.size(), q.dtype, max_rays);
        s.out.resize(n * answer_record_bytes(mode, q.dtype));
        if (const std::size_t bad =
                intersect_records(engine, s.body, q.dtype, q.options, 0, n, s.out.data());
            bad < n) {
            throw_invalid_ray(ray_at(s.body, q.dtype, bad), bad);
        }
    } else {
        decode_rays(s.body, q.dtype, max_rays, s.rays);
        engine.intersect(s.rays, q.options, s.result);
        encode_results(s.result, mode, q.dtype, s.rays.size(), s.out);
    }
    send_binary_answer(q, engine.effective_precision(q.options.precision), std::move(scratch), res);
}

void install_query_routes(App& app) {
    app.http().Post("/v1/intersect", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, true, [&] {
            if (is_binary(req)) {
                throw api_error("unsupported_format",
                                "binary rays need a registered scene: POST /v1/scenes, then "
                                "/v1/scenes/{id}/intersect");
            }
            const Json body = App::parse_json_body(req);
            require_object(body, "", "invalid_request");
            const Json* scene_doc = member(body, "scene");
            if (!scene_doc)
                throw api_error("invalid_request", "/scene is required", "/scene");
            auto engine = app.build_stateless_scene(*scene_doc, "/scene");
            answer_intersect(*engine, body, "", app.config().limits.max_rays, res);
        });
    });
}

}  // namespace raycastd::server
