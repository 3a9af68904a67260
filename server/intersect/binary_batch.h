#pragma once
// The binary form of intersect answered as a whole batch: the body has arrived, the answer is
// encoded into a pooled buffer and streamed from it (schema/binary_codec.h has the records).
// closest and any go a block at a time through intersect_records; count and all, whose
// answers vary in size per ray, through the engine's own rays and results. Large closest/any
// batches with a Content-Length take binary_stream.h instead, which traces through the same
// intersect_records, so both paths answer byte for byte alike.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string_view>

#include <httplib.h>

#include "engine/query/intersect.h"
#include "server/request_cancel.h"
#include "server/schema/binary_codec.h"
#include "server/scratch.h"

namespace raycastd::server {

/// True when the request carries binary ray records (Content-Type: application/octet-stream).
bool is_binary(const httplib::Request& req);

/// The query string of the binary form: ?mode=&precision=&dtype=&fields=.
struct BinaryQuery {
    engine::QueryOptions options;
    Dtype dtype = Dtype::float32;
};
/// invalid_request for an unknown mode, precision or dtype. Normals are computed unless
/// `fields` is given without `normal`.
BinaryQuery parse_binary_query(const httplib::Request& req);

/// closest or any for records [begin, end) of `body` (begin a multiple of
/// QueryEngine::kBlockRays), answered into `out` at (i − begin) × answer_record_bytes, through
/// QueryEngine::intersect_blocks: records are decoded, checked, traced and encoded a block at a
/// time, so the batch never exists as engine rays and hits (1M rays: 136 MB less memory traffic
/// than decode_rays + intersect + encode_results). Returns the lowest index of a bad record, or
/// `end` if all are good; once one is found, blocks not yet traced are skipped (their answers
/// are left unwritten: the request is an error). So are they once options.cancel fires, which
/// the caller asks (options.cancel.fired()) before it trusts an answer.
std::size_t intersect_records(const engine::QueryEngine& engine, std::string_view body, Dtype dtype,
                              const engine::QueryOptions& options, std::size_t begin,
                              std::size_t end, char* out);

/// Starts a 200 answer of `bytes` binary bytes, `provider` writing them, with the X-Precision
/// and X-Mode headers saying which path and mode answered.
void send_records(httplib::Response& res, engine::Precision precision, engine::Mode mode,
                  std::size_t bytes, httplib::ContentProvider provider);

/// Answers the batch in scratch->body (invalid_ray naming the lowest bad ray, too_large over
/// max_rays); the answer streams from scratch->out, and the response keeps `scratch` until it
/// has been written. q.options.cancel must be `cancel`'s token: once it fires the tracing
/// stops, the scratch is freed rather than pooled, and what `cancel` says is thrown.
/// `charge_answer` (App::charge_answer) is told the answer's bytes before they are allocated
/// (closest, any, count: known from the ray count) and again once encoded (all), and throws to
/// refuse them.
void answer_binary_batch(const engine::QueryEngine& engine, const BinaryQuery& q,
                         std::shared_ptr<Scratch> scratch, std::size_t max_rays,
                         const RequestCancel& cancel,
                         const std::function<void(std::uint64_t)>& charge_answer,
                         httplib::Response& res);

}  // namespace raycastd::server
