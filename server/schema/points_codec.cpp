#include "server/schema/points_codec.h"

#include <cmath>
#include <cstring>
#include <limits>

#include "server/api_error.h"

namespace raycastd::server {

namespace {

template <class F>
char* put(char* p, F v) {
    std::memcpy(p, &v, sizeof v);
    return p + sizeof v;
}

template <class F>
std::size_t decode_as(std::string_view body, std::vector<engine::Vec3d>& points) {
    const std::size_t n = points.size();
    const char* p = body.data();
    for (std::size_t i = 0; i < n; ++i, p += 3 * sizeof(F)) {
        F v[3];
        std::memcpy(v, p, sizeof v);
        points[i] = {double(v[0]), double(v[1]), double(v[2])};
        if (!engine::is_finite(points[i]))
            return i;
    }
    return n;
}

template <class F>
void encode_as(const std::vector<engine::PointAnswer>& answers, engine::PointQuery query,
               std::string& out) {
    constexpr F kInf = std::numeric_limits<F>::infinity();
    out.resize(answers.size() *
               point_answer_bytes(query, sizeof(F) == 4 ? Dtype::float32 : Dtype::float64));
    char* p = out.data();
    for (const engine::PointAnswer& a : answers) {
        switch (query) {
            case engine::PointQuery::closest: {
                const engine::PointHit& h = a.hit;
                const bool found = h.valid();
                p = put<F>(p, found ? static_cast<F>(h.point.x) : F(0));
                p = put<F>(p, found ? static_cast<F>(h.point.y) : F(0));
                p = put<F>(p, found ? static_cast<F>(h.point.z) : F(0));
                p = put<F>(p, found ? static_cast<F>(h.distance) : kInf);
                p = put<std::uint32_t>(p, h.object);
                p = put<std::uint32_t>(p, h.primitive);
                p = put<F>(p, found ? static_cast<F>(h.u) : F(0));
                p = put<F>(p, found ? static_cast<F>(h.v) : F(0));
                break;
            }
            case engine::PointQuery::distance:
            case engine::PointQuery::signed_distance:
                p = put<F>(p, static_cast<F>(a.distance));
                break;
            case engine::PointQuery::occupancy:
                p = put<F>(p, static_cast<F>(a.winding));
                break;
        }
    }
}

}  // namespace

std::size_t point_answer_bytes(engine::PointQuery query, Dtype dtype) {
    const std::size_t f = dtype == Dtype::float32 ? 4 : 8;
    return query == engine::PointQuery::closest ? 6 * f + 2 * sizeof(std::uint32_t) : f;
}

void decode_points(std::string_view body, Dtype dtype, std::size_t max_points,
                   std::vector<engine::Vec3d>& points) {
    const std::size_t rec = point_record_bytes(dtype);
    if (body.size() % rec != 0) {
        throw ApiError(ErrorCode::invalid_request, "body of " + std::to_string(body.size()) +
                                                       " bytes is not a whole number of " +
                                                       std::to_string(rec) + "-byte point records");
    }
    const std::size_t n = body.size() / rec;
    if (n > max_points) {
        throw ApiError(ErrorCode::too_large, std::to_string(n) + " points is over the limit of " +
                                                 std::to_string(max_points) + " per request");
    }
    points.resize(n);
    const std::size_t bad =
        dtype == Dtype::float32 ? decode_as<float>(body, points) : decode_as<double>(body, points);
    if (bad < n) {
        throw ApiError(ErrorCode::invalid_request,
                       "point " + std::to_string(bad) + ": coordinates must be finite",
                       "/points/" + std::to_string(bad));
    }
}

void encode_point_answers(const std::vector<engine::PointAnswer>& answers, engine::PointQuery query,
                          Dtype dtype, std::string& out) {
    if (dtype == Dtype::float32) {
        encode_as<float>(answers, query, out);
    } else {
        encode_as<double>(answers, query, out);
    }
}

}  // namespace raycastd::server
