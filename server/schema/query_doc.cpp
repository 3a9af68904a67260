#include "server/schema/query_doc.h"

#include <algorithm>

#include <tbb/parallel_for.h>

#include "server/schema/json_writer.h"

namespace raycastd::server {

namespace {

constexpr ErrorCode kInvalidRay = ErrorCode::invalid_ray;
constexpr ErrorCode kInvalidRequest = ErrorCode::invalid_request;

engine::Ray parse_ray(const Json& j, const std::string& path, std::size_t index) {
    if (!j.is_object())
        throw ApiError(kInvalidRay, "ray " + std::to_string(index) + " must be an object", path);
    engine::Ray r;
    const Json* o = member(j, "origin");
    if (!o)
        throw ApiError(kInvalidRay, "ray " + std::to_string(index) + ": origin is required",
                       path + "/origin");
    r.origin = read_vec3(*o, path + "/origin", kInvalidRay);
    const Json* d = member(j, "direction");
    if (!d)
        throw ApiError(kInvalidRay, "ray " + std::to_string(index) + ": direction is required",
                       path + "/direction");
    r.direction = read_vec3(*d, path + "/direction", kInvalidRay);
    if (const Json* v = member(j, "tmin"))
        r.tmin = read_number(*v, path + "/tmin", kInvalidRay);
    if (const Json* v = member(j, "tmax"))
        r.tmax = read_number(*v, path + "/tmax", kInvalidRay);
    engine::Status st = engine::validate_ray(r, index);
    if (!st.ok()) {
        // validate_ray names "/rays/i/..."; re-root it under this request's prefix.
        const std::string rays_prefix = path.substr(0, path.rfind("/rays/"));
        throw from_status(st, rays_prefix);
    }
    return r;
}

}  // namespace

namespace {

/// Sets the part of `m` that field name `f` asks for; invalid_request at `path` for an unknown
/// name.
void add_field(FieldMask& m, const std::string& f, const std::string& path) {
    if (f == "t")
        m.t = true;
    else if (f == "t_err")
        m.t_err = true;
    else if (f == "point")
        m.point = true;
    else if (f == "normal")
        m.normal = m.front_face = true;
    else if (f == "front_face")
        m.front_face = true;
    else if (f == "object")
        m.object = true;
    else if (f == "name")
        m.name = true;
    else if (f == "primitive")
        m.primitive = true;
    else if (f == "barycentric")
        m.barycentric = true;
    else
        throw ApiError(kInvalidRequest,
                       "unknown field \"" + f +
                           "\" (expected t, t_err, point, normal, front_face, object, name, "
                           "primitive, barycentric)",
                       path);
}

constexpr FieldMask kNoFields{false, false, false, false, false, false, false, false, false};

}  // namespace

FieldMask parse_fields(const Json& j, const std::string& path) {
    if (!j.is_array())
        throw ApiError(kInvalidRequest, path + " must be an array of names", path);
    FieldMask m = kNoFields;
    for (std::size_t i = 0; i < j.size(); ++i) {
        const std::string p = child_path(path, i);
        add_field(m, read_string(j.at(i), p, kInvalidRequest), p);
    }
    return m;
}

FieldMask parse_field_list(const std::string& list, const std::string& path) {
    // An empty list is one empty name, refused as docs/api.md says (`?fields=` had been taken
    // as "no fields": a helper's review).
    FieldMask m = kNoFields;
    std::size_t start = 0;
    while (true) {
        const std::size_t comma = list.find(',', start);
        add_field(m, list.substr(start, comma - start), path);
        if (comma == std::string::npos)
            return m;
        start = comma + 1;
    }
}

namespace {

void write_hit(JsonWriter& w, const engine::QueryEngine& engine, const engine::Ray& ray,
               const engine::Hit& h, const FieldMask& f) {
    w.raw("{\"hit\":true");
    if (f.t)
        w.raw(",\"t\":").number(h.t);
    if (f.t_err)
        w.raw(",\"t_err\":").number(h.t_err);
    if (f.point)
        w.raw(",\"point\":").vec(engine.point_of(ray, h));
    if (f.normal)
        w.raw(",\"normal\":").vec(h.normal);
    if (f.front_face)
        w.raw(",\"front_face\":").boolean(h.front_face);
    if (f.object)
        w.raw(",\"object\":").integer(h.object);
    if (f.name)
        w.raw(",\"name\":").string(engine.scene().objects[h.object].name);
    if (f.primitive)
        w.raw(",\"primitive\":").integer(h.primitive);
    if (f.barycentric)
        w.raw(",\"barycentric\":[").number(h.u).ch(',').number(h.v).ch(']');
    w.ch('}');
}

}  // namespace

engine::Mode parse_mode(const std::string& s, const std::string& path) {
    if (s == "closest")
        return engine::Mode::closest;
    if (s == "any")
        return engine::Mode::any;
    if (s == "all")
        return engine::Mode::all;
    if (s == "count")
        return engine::Mode::count;
    throw ApiError(kInvalidRequest,
                   "unknown mode \"" + s + "\" (expected closest, any, all, count)", path);
}

engine::Precision parse_precision(const std::string& s, const std::string& path) {
    if (s == "fast")
        return engine::Precision::fast;
    if (s == "refined")
        return engine::Precision::refined;
    if (s == "exact")
        return engine::Precision::exact;
    throw ApiError(kInvalidRequest,
                   "unknown precision \"" + s + "\" (expected fast, refined, exact)", path);
}

IntersectRequest parse_intersect_request(const Json& body, const std::string& prefix,
                                         std::size_t max_rays) {
    require_object(body, prefix, kInvalidRequest);
    IntersectRequest req;
    if (const Json* m = member(body, "mode")) {
        req.options.mode =
            parse_mode(read_string(*m, prefix + "/mode", kInvalidRequest), prefix + "/mode");
    }
    if (const Json* p = member(body, "precision")) {
        req.options.precision = parse_precision(
            read_string(*p, prefix + "/precision", kInvalidRequest), prefix + "/precision");
    }
    if (const Json* f = member(body, "fields"))
        req.fields = parse_fields(*f, prefix + "/fields");
    req.options.want_normal = req.fields.needs_normals();

    const Json* rays = member(body, "rays");
    const std::string rpath = prefix + "/rays";
    if (!rays)
        throw ApiError(kInvalidRequest, rpath + " is required", rpath);
    if (!rays->is_array())
        throw ApiError(kInvalidRequest, rpath + " must be an array", rpath);
    if (rays->size() > max_rays) {
        throw ApiError(ErrorCode::too_large,
                       std::to_string(rays->size()) + " rays is over the limit of " +
                           std::to_string(max_rays) + " per request",
                       rpath);
    }
    req.rays.reserve(rays->size());
    for (std::size_t i = 0; i < rays->size(); ++i) {
        req.rays.push_back(parse_ray(rays->at(i), child_path(rpath, i), i));
    }
    return req;
}

namespace {

/// Appends the result entries of rays [begin, end) to `out`.
void write_entries(const engine::QueryEngine& engine, const IntersectRequest& req,
                   const engine::QueryResult& r, std::size_t begin, std::size_t end,
                   std::string& out) {
    JsonWriter w(out);
    for (std::size_t i = begin; i < end; ++i) {
        if (i)
            w.ch(',');
        switch (req.options.mode) {
            case engine::Mode::closest:
                if (r.hits[i].valid()) {
                    write_hit(w, engine, req.rays[i], r.hits[i], req.fields);
                } else {
                    w.raw("{\"hit\":false}");
                }
                break;
            case engine::Mode::any:
                w.raw("{\"hit\":").boolean(r.hits[i].valid()).ch('}');
                break;
            case engine::Mode::count:
                w.raw("{\"count\":").integer(r.counts[i]).ch('}');
                break;
            case engine::Mode::all: {
                const std::uint32_t b = r.offsets[i], e = r.offsets[i + 1];
                w.raw("{\"count\":").integer(e - b).raw(",\"hits\":[");
                for (std::uint32_t k = b; k < e; ++k) {
                    if (k != b)
                        w.ch(',');
                    write_hit(w, engine, req.rays[i], r.hits[k], req.fields);
                }
                w.raw("]}");
                break;
            }
        }
    }
}

/// Rays per chunk when a large response is written on several threads.
constexpr std::size_t kWriteChunk = 8192;

}  // namespace

std::string write_intersect_response(const engine::QueryEngine& engine, const IntersectRequest& req,
                                     const engine::QueryResult& r) {
    std::string out;
    const std::size_t n = req.rays.size();
    out.reserve(64 + n * 220);
    JsonWriter w(out);
    w.raw("{\"precision\":").string(engine::to_string(r.precision));
    w.raw(",\"mode\":").string(engine::to_string(req.options.mode)).raw(",\"hits\":[");
    if (n <= kWriteChunk) {
        write_entries(engine, req, r, 0, n, out);
    } else {
        // Formatting numbers costs more than tracing the rays: big responses are written in
        // chunks on all cores, then joined.
        const std::size_t chunks = (n + kWriteChunk - 1) / kWriteChunk;
        std::vector<std::string> parts(chunks);
        tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
            const std::size_t b = c * kWriteChunk, e = std::min(n, b + kWriteChunk);
            parts[c].reserve((e - b) * 220);
            write_entries(engine, req, r, b, e, parts[c]);
        });
        for (const auto& p : parts)
            out.append(p);
    }
    w.raw("]}");
    return out;
}

}  // namespace raycastd::server
