// The intersect request, both routes: POST /v1/intersect (stateless: JSON with an inline scene)
// and POST /v1/scenes/{id}/intersect (a registered scene: JSON, or binary records).
//
// A registered scene's request takes one of four paths, chosen in this order:
//   1. binary closest/any of at least one chunk with a Content-Length: traced while it arrives
//      and answered chunk by chunk (binary_stream.h);
//   2. other binary requests: the whole batch once the body is in (binary_batch.h);
//   3. JSON in the usual shape: the ray scanner (schema/ray_scanner.h), no DOM;
//   4. any other JSON: parse_json and the DOM reader, whose answers and errors are the reference.

#include <charconv>

#include "server/app.h"
#include "server/intersect/binary_batch.h"
#include "server/intersect/binary_stream.h"
#include "server/request_cancel.h"
#include "server/request_log.h"
#include "server/schema/query_doc.h"
#include "server/schema/ray_scanner.h"
#include "server/scratch.h"

namespace raycastd::server {

namespace {

/// Answers a parsed JSON request, the engine answering into `result` (stopping when `cancel`
/// fires).
void answer_json(App& app, const engine::QueryEngine& engine, const IntersectRequest& req,
                 const RequestCancel& cancel, engine::QueryResult& result, httplib::Response& res) {
    // Charged before the work on an estimate; App::handle charges the exact size once written.
    app.charge_answer(req.rays.size() * App::kJsonBytesPerItem);
    engine::QueryOptions options = req.options;
    options.cancel = cancel.token();
    cancel.check(engine.intersect(req.rays, options, result));
    note_rays(ray_kind(options.mode), engine.effective_precision(options.precision),
              req.rays.size());
    send_json(res, write_intersect_response(engine, req, result));
}

/// Reads `body` with the DOM reader and answers it over `engine` into `result`.
void answer_json_document(App& app, const engine::QueryEngine& engine, const Json& body,
                          const RequestCancel& cancel, engine::QueryResult& result,
                          httplib::Response& res) {
    answer_json(app, engine, parse_intersect_request(body, "", app.config().limits.max_rays),
                cancel, result, res);
}

/// Frees `scratch` instead of pooling it when the request's work was cancelled: an abandoned
/// batch hands its hundreds of megabytes back at once.
void discard_if_cancelled(Scratch& scratch, const RequestCancel& cancel) {
    if (cancel.token().fired())
        scratch.discard = true;
}

/// A StreamedBatch for a binary closest/any request on a registered scene that announces a
/// valid batch of at least one chunk within the limits; nullptr otherwise: that request reads
/// its whole body first, and reports whatever is wrong with it (an unknown scene, a bad
/// parameter, a bad length) after reading it.
std::shared_ptr<StreamedBatch> plan_streamed(App& app, const httplib::Request& req,
                                             const std::shared_ptr<Scratch>& scratch,
                                             const RequestCancel& cancel) {
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
        BinaryQuery q = parse_binary_query(req);
        if (q.options.mode != engine::Mode::closest && q.options.mode != engine::Mode::any)
            return nullptr;
        q.options.cancel = cancel.token();
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

/// POST /v1/scenes/{id}/intersect, on one of the four paths of the file comment.
void answer_registered(App& app, const httplib::Request& req, httplib::Response& res,
                       const httplib::ContentReader& read, const RequestCancel& cancel) {
    const Limits& limits = app.config().limits;
    // The body is streamed into a pooled buffer and binary answers are written from another
    // (server/scratch.h): a 1M-ray batch moves 32-64 MB each way, and fresh buffers of that
    // size cost more in page faults than tracing the rays (~2.5 ms per MB).
    auto scratch = acquire_scratch();
    scratch->body.clear();
    auto stream = plan_streamed(app, req, scratch, cancel);
    // Refused before a byte of the body is read: the connection then closes (http_server.h).
    if (stream)
        app.charge_answer(stream->answer_bytes());
    // Bounded as decoded (a gzip body), and never taken for whole when cut off: a streamed
    // batch's finish() names how short it fell, any other batch is refused here.
    const bool complete = app.read_body(req, read, [&](const char* data, std::size_t len) {
        if (stream)
            return stream->append(data, len);
        scratch->body.append(data, len);
        return true;
    });
    if (stream) {
        // A client gone mid-upload, or the time limit passed while the body arrived.
        if (cancel.token().cancelled()) {
            scratch->discard = true;
            cancel.stopped();
        }
        stream->finish();
        // Counted as submitted: the rays of a streamed batch are traced while it is written.
        note_rays(ray_kind(stream->mode()), stream->precision(), stream->rays());
        send_streamed_answer(std::move(stream), app.extend_work_slot(), res);
        return;
    }
    if (!complete)
        throw App::body_cut_off();
    auto engine = app.scene_or_404(req.matches[1]);
    if (is_binary(req)) {
        BinaryQuery q = parse_binary_query(req);
        q.options.cancel = cancel.token();
        answer_binary_batch(
            *engine, q, std::move(scratch), limits.max_rays, cancel,
            [&app](std::uint64_t bytes) { app.charge_answer(bytes); }, res);
        return;
    }
    IntersectRequest& scanned = scratch->parsed;
    scanned.rays.clear();  // keeps its capacity for the next request
    scanned.options = {};
    scanned.fields = {};
    try {
        if (scan_intersect_request(scratch->body, limits.max_rays, scanned)) {
            answer_json(app, *engine, scanned, cancel, scratch->result, res);
            return;
        }
        answer_json_document(app, *engine, parse_json(scratch->body), cancel, scratch->result, res);
    } catch (...) {
        discard_if_cancelled(*scratch, cancel);
        throw;
    }
}

/// POST /v1/intersect: JSON only, the scene inline (built or taken from the stateless cache).
void answer_stateless(App& app, const httplib::Request& req, httplib::Response& res,
                      const RequestCancel& cancel) {
    if (is_binary(req)) {
        throw ApiError(ErrorCode::unsupported_format,
                       "binary rays need a registered scene: POST /v1/scenes, then "
                       "/v1/scenes/{id}/intersect");
    }
    const Json body = parse_json(req.body);
    auto engine =
        cancel.guard([&] { return app.models().build_stateless_scene(body, cancel.token()); });
    const auto scratch = acquire_scratch();
    try {
        answer_json_document(app, *engine, body, cancel, scratch->result, res);
    } catch (...) {
        discard_if_cancelled(*scratch, cancel);
        throw;
    }
}

}  // namespace

void install_intersect_routes(App& app) {
    app.on_post("/v1/intersect", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, Work::heavy, [&] {
            answer_stateless(app, req, res,
                             RequestCancel::for_current_request(app.config().limits));
        });
    });
    app.on_post(R"(/v1/scenes/([A-Za-z0-9_]+)/intersect)",
                [&app](const httplib::Request& req, httplib::Response& res,
                       const httplib::ContentReader& read) {
                    app.handle(req, res, Work::heavy, [&] {
                        answer_registered(app, req, res, read,
                                          RequestCancel::for_current_request(app.config().limits));
                    });
                });
}

}  // namespace raycastd::server
