#include "server/intersect/binary_batch.h"

#include <atomic>
#include <string>

#include "server/request_log.h"
#include "server/schema/query_doc.h"

namespace raycastd::server {

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
    // Absent means float32; present, even empty (`?dtype=`), it must name one.
    q.dtype = req.has_param("dtype") ? parse_dtype(param("dtype")) : Dtype::float32;
    opt.want_normal = true;
    if (req.has_param("fields")) {
        // ?fields=t,object: normals are left out (zeros) unless asked for. The names are the
        // JSON form's; an unknown one is refused (until 2026-12-05 any text was taken, and
        // ?fields=normals asked for normals).
        opt.want_normal = parse_field_list(param("fields"), "fields").normal;
    }
    return q;
}

std::size_t intersect_records(const engine::QueryEngine& engine, std::string_view body, Dtype dtype,
                              const engine::QueryOptions& options, std::size_t begin,
                              std::size_t end, char* out) {
    std::atomic<std::size_t> first_bad{end};
    const auto source = [&](std::size_t b, std::size_t e, engine::Ray* rays) {
        const std::size_t bad = decode_ray_range(body, dtype, begin + b, begin + e, rays);
        if (bad < begin + e) {
            lower_to(first_bad, bad);
            return false;
        }
        // Every block is still checked (the lowest bad index is the answer), but none is
        // traced once the request is known to be an error.
        return first_bad.load() == end;
    };
    const std::size_t record = answer_record_bytes(options.mode, dtype);
    const auto sink = [&](std::size_t b, std::size_t e, const engine::Hit* hits) {
        encode_answers(hits, options.mode, dtype, 0, e - b, out + b * record);
    };
    // Its Status says whether options.cancel fired, which the caller asks the token itself.
    engine.intersect_blocks(end - begin, options, source, sink);
    return first_bad.load();
}

void send_records(httplib::Response& res, engine::Precision precision, engine::Mode mode,
                  std::size_t bytes, httplib::ContentProvider provider) {
    res.status = 200;
    res.set_header("X-Precision", engine::to_string(precision));
    res.set_header("X-Mode", engine::to_string(mode));
    // An empty answer (no rays) is an empty body: cpp-httplib 0.11.4 takes a provider of length
    // 0 for one without a length, sends no Content-Length, and calls it until it reports done,
    // which ours never does, so the thread spun forever (found by tests/fuzz/fuzz_http_routes).
    if (bytes == 0) {
        res.set_content(std::string(), "application/octet-stream");
        return;
    }
    res.set_content_provider(bytes, "application/octet-stream", std::move(provider));
}

void answer_binary_batch(const engine::QueryEngine& engine, const BinaryQuery& q,
                         std::shared_ptr<Scratch> scratch, std::size_t max_rays,
                         const RequestCancel& cancel,
                         const std::function<void(std::uint64_t)>& charge_answer,
                         httplib::Response& res) {
    Scratch& s = *scratch;
    const engine::Mode mode = q.options.mode;
    // An abandoned batch frees its buffers rather than pooling them.
    const auto stopped = [&] {
        s.discard = true;
        cancel.stopped();
    };
    if (mode == engine::Mode::closest || mode == engine::Mode::any) {
        // Records in, records out, a block at a time (intersect_records).
        const std::size_t n = ray_count(s.body.size(), q.dtype, max_rays);
        charge_answer(n * answer_record_bytes(mode, q.dtype));
        s.out.resize(n * answer_record_bytes(mode, q.dtype));
        const std::size_t bad =
            intersect_records(engine, s.body, q.dtype, q.options, 0, n, s.out.data());
        if (q.options.cancel.fired())
            stopped();
        if (bad < n)
            throw_invalid_ray(ray_at(s.body, q.dtype, bad), bad);
        note_rays(ray_kind(mode), engine.effective_precision(q.options.precision), n);
    } else {
        decode_rays(s.body, q.dtype, max_rays, s.rays);
        // At least a count per ray; `all` adds its hits, charged once they are encoded.
        charge_answer(s.rays.size() * answer_record_bytes(engine::Mode::count, q.dtype));
        if (!engine.intersect(s.rays, q.options, s.result).ok())
            stopped();  // the only Status intersect() returns: its token fired
        encode_results(s.result, mode, q.dtype, s.rays.size(), s.out);
        charge_answer(s.out.size());
        note_rays(ray_kind(mode), engine.effective_precision(q.options.precision), s.rays.size());
    }
    const std::size_t bytes = s.out.size();
    // The provider keeps the scratch (and so `out`) until the response has been written.
    send_records(res, engine.effective_precision(q.options.precision), mode, bytes,
                 [scratch = std::move(scratch)](std::size_t offset, std::size_t length,
                                                httplib::DataSink& sink) {
                     // A client gone before the answer was written: freed, not pooled.
                     if (sink.write(scratch->out.data() + offset, length))
                         return true;
                     scratch->discard = true;
                     return false;
                 });
}

}  // namespace raycastd::server
