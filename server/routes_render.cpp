// POST /v1/scenes/{id}/render, GET/DELETE /v1/jobs/{job}, GET /v1/jobs/{job}/image.

#include <chrono>
#include <cstdio>
#include <memory>

#include "engine/render/render.h"
#include "server/app.h"
#include "server/job_queue.h"
#include "server/request_cancel.h"
#include "server/request_log.h"
#include "server/schema/json_writer.h"
#include "server/schema/render_doc.h"

namespace raycastd::server {

namespace {

/// Finished jobs whose images are kept for GET /v1/jobs/{job}/image.
constexpr std::size_t kJobsKept = 32;

/// Renders (stopping when `cancel` fires: Code::cancelled) and encodes; the response headers
/// say how long it took and which rays it traced.
engine::Result<JobOutput> render_output(const engine::QueryEngine& engine, const RenderRequest& req,
                                        engine::RenderProgress* progress,
                                        const engine::CancelToken& cancel, Metrics& metrics) {
    engine::RenderOptions options = req.options;
    options.cancel = cancel;
    const auto rendered = engine::render(engine, options, progress);
    if (!rendered.ok())
        return rendered.status();
    const engine::RenderResult& r = *rendered;
    note_rays(metrics, RayKind::primary, r.precision, r.counts.primary);
    note_rays(metrics, RayKind::shadow, r.precision, r.counts.shadow);
    note_rays(metrics, RayKind::reflected, r.precision, r.counts.reflected);
    note_rays(metrics, RayKind::refracted, r.precision, r.counts.refracted);
    JobOutput out;
    const auto encode_start = std::chrono::steady_clock::now();
    out.body = engine::encode_image(r.image, req.format, engine::is_data_mode(req.options.shading));
    const double encode_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - encode_start)
            .count();
    out.content_type = engine::mime_type(req.format);
    char ms[32], breakdown[96];
    std::snprintf(ms, sizeof ms, "%.3f", r.render_ms);
    // X-Render-Ms stays one number (clients parse it); where the time went is beside it.
    std::snprintf(breakdown, sizeof breakdown, "trace=%.3f, encode=%.3f", r.render_ms, encode_ms);
    out.headers = {{"X-Render-Ms", ms},
                   {"X-Render-Breakdown", breakdown},
                   {"X-Rays", rays_header(r.counts)},
                   {"X-Precision", engine::to_string(r.precision)}};
    return out;
}

void send_output(httplib::Response& res, const JobOutput& out) {
    for (const auto& [k, v] : out.headers)
        res.set_header(k, v);
    res.status = 200;
    res.set_content(out.body, out.content_type);
}

std::string job_body(const JobInfo& j) {
    std::string out;
    JsonWriter w(out);
    w.raw("{\"job\":").string(j.id);
    w.raw(",\"state\":").string(to_string(j.state));
    w.raw(",\"progress\":").number(j.progress);
    w.raw(",\"eta_s\":");
    if (j.eta_s) {
        w.number(*j.eta_s);
    } else {
        w.raw("null");
    }
    w.raw(",\"elapsed_s\":").number(j.elapsed_s);
    w.raw(",\"tiles_done\":").integer(j.tiles_done);
    w.raw(",\"tiles_total\":").integer(j.tiles_total);
    if (j.state == JobState::done) {
        w.raw(",\"image\":").string("/v1/jobs/" + j.id + "/image");
        for (const auto& [k, v] : j.output->headers) {
            if (k == "X-Render-Ms")
                w.raw(",\"render_ms\":").raw(v);
            if (k == "X-Render-Breakdown")
                w.raw(",\"render_breakdown\":").string(v);
            if (k == "X-Rays")
                w.raw(",\"rays\":").string(v);
        }
    }
    if (j.error) {
        w.raw(",\"error\":{\"code\":").string(to_string(j.error->code));
        w.raw(",\"message\":").string(j.error->what()).ch('}');
    }
    w.ch('}');
    return out;
}

ApiError job_not_found(const std::string& id) {
    return ApiError(ErrorCode::job_not_found, "no job with id " + id);
}

}  // namespace

void install_render_routes(App& app) {
    // The queue lives as long as the routes that use it (the App's server); its destructor
    // cancels what is still running and joins its worker.
    auto jobs = std::make_shared<JobQueue>(app.max_concurrent(), kJobsKept,
                                           app.config().limits.job_budget_bytes);
    app.metrics().add_gauge("raycastd_jobs_queued", "gauge", "Async render jobs waiting.",
                            [jobs] { return static_cast<double>(jobs->counts().queued); });
    app.metrics().add_gauge("raycastd_jobs_running", "gauge", "Async render jobs rendering.",
                            [jobs] { return static_cast<double>(jobs->counts().running); });
    app.metrics().add_gauge(
        "raycastd_job_image_bytes", "gauge",
        "Bytes of finished async render images kept (--job-budget-mb bounds it).",
        [jobs] { return static_cast<double>(jobs->counts().image_bytes); });
    app.metrics().add_gauge(
        "raycastd_job_budget_bytes", "gauge", "The finished job images' budget (--job-budget-mb).",
        [&app] { return static_cast<double>(app.config().limits.job_budget_bytes); });
    app.metrics().add_gauge(
        "raycastd_jobs_evicted_total", "counter",
        "Finished jobs forgotten, oldest first, to keep within 32 jobs and --job-budget-mb.",
        [jobs] { return static_cast<double>(jobs->counts().evicted); });

    app.on_post(R"(/v1/scenes/([A-Za-z0-9_]+)/render)", [&app, jobs](const httplib::Request& req,
                                                                     httplib::Response& res) {
        app.handle(req, res, Work::heavy, [&] {
            const auto cancel = RequestCancel::for_current_request(app.config().limits);
            auto engine = app.scene_or_404(req.matches[1]);
            const Json body = req.body.empty() ? Json() : parse_json(req.body);
            const RenderRequest r = parse_render_request(body, app.config().limits.max_pixels);
            if (!r.async) {
                // The image being rendered (3 floats a pixel) and its encoding, charged before
                // the work; App::handle charges the encoded size once it is known.
                app.charge_answer(static_cast<std::uint64_t>(r.options.width) *
                                  static_cast<std::uint64_t>(r.options.height) *
                                  (3 * sizeof(float) + 4));
                const auto out = render_output(*engine, r, nullptr, cancel.token(), app.metrics());
                send_output(res, cancel.check(out));
                return;
            }
            // Not tied to this request: the job's own token, fired by DELETE /v1/jobs/{job}.
            auto id = jobs->submit(
                [engine, r, &metrics = app.metrics()](engine::RenderProgress& progress,
                                                      const engine::CancelToken& job_cancel) {
                    auto out = render_output(*engine, r, &progress, job_cancel, metrics);
                    if (!out.ok())
                        throw from_status(out.status());  // the queue sees the token: cancelled
                    return std::move(out).value();
                });
            if (!id) {
                throw ApiError(ErrorCode::busy,
                               "too many render jobs queued or running; "
                               "retry shortly");
            }
            res.set_header("Location", "/v1/jobs/" + *id);
            send_json(res, "{\"job\":\"" + *id + "\",\"state\":\"queued\"}", 202);
        });
    });

    app.on_get(R"(/v1/jobs/([A-Za-z0-9_]+))",
               [&app, jobs](const httplib::Request& req, httplib::Response& res) {
                   app.handle(req, res, Work::light, [&] {
                       auto info = jobs->info(req.matches[1]);
                       if (!info)
                           throw job_not_found(req.matches[1]);
                       send_json(res, job_body(*info));
                   });
               });

    app.on_get(R"(/v1/jobs/([A-Za-z0-9_]+)/image)",
               [&app, jobs](const httplib::Request& req, httplib::Response& res) {
                   app.handle(req, res, Work::light, [&] {
                       const std::string id = req.matches[1];
                       auto info = jobs->info(id);
                       if (!info)
                           throw job_not_found(id);
                       switch (info->state) {
                           case JobState::done:
                               send_output(res, *info->output);
                               return;
                           case JobState::failed:
                               throw *info->error;
                           case JobState::cancelled:
                               throw ApiError(ErrorCode::job_not_found,
                                              "job " + id + " was cancelled: it has no image");
                           case JobState::queued:
                           case JobState::running:
                               // Not yet: the job's status, as 202, with a hint when to ask again.
                               res.set_header("Retry-After", "1");
                               send_json(res, job_body(*info), 202);
                               return;
                       }
                   });
               });

    app.on_delete(R"(/v1/jobs/([A-Za-z0-9_]+))", [&app, jobs](const httplib::Request& req,
                                                              httplib::Response& res) {
        app.handle(req, res, Work::light, [&] {
            const std::string id = req.matches[1];
            auto before = jobs->info(id);
            auto after = jobs->cancel_or_remove(id);
            if (!before || !after)
                throw job_not_found(id);
            const bool cancelled =
                before->state == JobState::queued || before->state == JobState::running;
            send_json(res, "{\"job\":\"" + id + "\",\"state\":\"" +
                               to_string(cancelled ? JobState::cancelled : before->state) +
                               "\",\"cancelled\":" + (cancelled ? "true" : "false") +
                               ",\"deleted\":" + (cancelled ? "false" : "true") + "}");
        });
    });
}

}  // namespace raycastd::server
