// The points request: POST /v1/scenes/{id}/points (a registered scene: JSON, or binary records)
// and POST /v1/points (stateless: JSON with an inline scene). Closest points, distances, signed
// distances and occupancy (engine/points/point_queries.h); the schema is schema/points_doc.h
// (JSON) and schema/points_codec.h (binary).

#include "engine/points/point_queries.h"
#include "server/app.h"
#include "server/intersect/binary_batch.h"
#include "server/request_cancel.h"
#include "server/schema/points_codec.h"
#include "server/schema/points_doc.h"

namespace raycastd::server {

namespace {

/// Answers a parsed JSON request over `engine`, stopping when `cancel` fires
/// (server/request_cancel.h).
void answer_json(App& app, const engine::QueryEngine& engine, PointsRequest req,
                 const RequestCancel& cancel, httplib::Response& res) {
    Metrics& metrics = app.metrics();
    // Charged before the work on an estimate; App::handle charges the exact size once written.
    app.charge_answer(req.points.size() * App::kJsonBytesPerItem);
    std::vector<engine::PointAnswer> answers;
    req.options.cancel = cancel.token();
    cancel.check(engine::query_points(engine, req.points, req.options, answers));
    metrics.count_points(req.options.query, req.points.size());
    send_json(res, write_points_response(engine.scene(), req.options.query, answers));
}

/// Bytes of the largest binary points record: closest in float64 (px py pz distance u v and the
/// two uint32 ids).
constexpr std::uint64_t kMaxPointRecordBytes = 6 * 8 + 2 * 4;

/// The query string of the binary form: ?query=&dtype=&max_distance=.
struct BinaryPointsQuery {
    engine::PointOptions options;
    Dtype dtype = Dtype::float32;
};

BinaryPointsQuery parse_binary_points_query(const httplib::Request& req) {
    BinaryPointsQuery q;
    if (req.has_param("query"))
        q.options.query = parse_point_query(req.get_param_value("query"), "query");
    q.dtype = req.has_param("dtype") ? parse_dtype(req.get_param_value("dtype")) : Dtype::float32;
    if (req.has_param("max_distance")) {
        const std::string v = req.get_param_value("max_distance");
        std::size_t used = 0;
        double d = -1;
        try {
            d = std::stod(v, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used != v.size() || v.empty())
            throw ApiError(ErrorCode::invalid_request, "max_distance must be a number",
                           "max_distance");
        q.options.max_distance = parse_max_distance(d, "max_distance");
    }
    return q;
}

void answer_binary(App& app, const engine::QueryEngine& engine, const httplib::Request& req,
                   const RequestCancel& cancel, httplib::Response& res) {
    Metrics& metrics = app.metrics();
    BinaryPointsQuery q = parse_binary_points_query(req);
    std::vector<engine::Vec3d> points;
    decode_points(req.body, q.dtype, app.config().limits.max_points, points);
    // The largest record (closest, float64: 7 numbers and two ids) until the exact size is known.
    app.charge_answer(points.size() * kMaxPointRecordBytes);
    std::vector<engine::PointAnswer> answers;
    q.options.cancel = cancel.token();
    cancel.check(engine::query_points(engine, points, q.options, answers));
    metrics.count_points(q.options.query, points.size());
    std::string out;
    encode_point_answers(answers, q.options.query, q.dtype, out);
    res.status = 200;
    res.set_header("X-Query", engine::to_string(q.options.query));
    res.set_content(std::move(out), "application/octet-stream");
}

}  // namespace

void install_points_routes(App& app) {
    app.on_post("/v1/points", [&app](const httplib::Request& req, httplib::Response& res) {
        app.handle(req, res, Work::heavy, [&] {
            const RequestCancel cancel = RequestCancel::for_current_request(app.config().limits);
            if (is_binary(req)) {
                throw ApiError(ErrorCode::unsupported_format,
                               "binary points need a registered scene: POST /v1/scenes, then "
                               "/v1/scenes/{id}/points");
            }
            const Json body = parse_json(req.body);
            auto engine = cancel.guard(
                [&] { return app.models().build_stateless_scene(body, cancel.token()); });
            answer_json(app, *engine,
                        parse_points_request(body, "", app.config().limits.max_points), cancel,
                        res);
        });
    });
    app.on_post(R"(/v1/scenes/([A-Za-z0-9_]+)/points)", [&app](const httplib::Request& req,
                                                               httplib::Response& res) {
        app.handle(req, res, Work::heavy, [&] {
            const RequestCancel cancel = RequestCancel::for_current_request(app.config().limits);
            auto engine = app.scene_or_404(req.matches[1]);
            if (is_binary(req)) {
                answer_binary(app, *engine, req, cancel, res);
                return;
            }
            answer_json(
                app, *engine,
                parse_points_request(parse_json(req.body), "", app.config().limits.max_points),
                cancel, res);
        });
    });
}

}  // namespace raycastd::server
