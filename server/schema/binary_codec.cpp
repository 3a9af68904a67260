#include "server/schema/binary_codec.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <type_traits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "engine/query/intersect.h"
#include "server/api_error.h"

namespace raycastd::server {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the binary format is little-endian and is copied as is");

namespace {

/// Runs f(begin, end) over [0, n) in blocks on every core when n is large: decoding, checking
/// and encoding 1M records is ~15 ms a core, worth sharing (tbb's grain keeps small batches
/// on the calling thread).
template <class F>
void for_blocks(std::size_t n, F&& f) {
    constexpr std::size_t kGrain = 16384;
    if (n <= kGrain) {
        f(std::size_t(0), n);
        return;
    }
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kGrain),
                      [&](const tbb::blocked_range<std::size_t>& r) { f(r.begin(), r.end()); });
}

/// Records [begin, end) of `body` into out[0 .. end-begin), each checked as it is decoded: the
/// index of the first bad one (decoded, the rest not), or `end`.
template <class F>
std::size_t decode_as(std::string_view body, std::size_t begin, std::size_t end, engine::Ray* out) {
    const char* p = body.data() + begin * 8 * sizeof(F);
    for (std::size_t i = begin; i < end; ++i, p += 8 * sizeof(F)) {
        F v[8];
        std::memcpy(v, p, sizeof v);
        engine::Ray& r = out[i - begin];
        r.origin = {double(v[0]), double(v[1]), double(v[2])};
        r.direction = {double(v[3]), double(v[4]), double(v[5])};
        r.tmin = double(v[6]);
        r.tmax = double(v[7]);
        if constexpr (std::is_same_v<F, float>) {
            // A float32 answer writes t as a float: a hit beyond FLT_MAX along the ray (a
            // denormal direction, (0,0,1e-45), puts an ordinary surface at t ~ 1e45) would be
            // written as +inf with an object id, which reads as neither a hit nor a miss. So a
            // float32 ray ends at FLT_MAX: what lies farther is a miss, as for any tmax.
            r.tmin = std::min(r.tmin, double(std::numeric_limits<float>::max()));
            r.tmax = std::min(r.tmax, double(std::numeric_limits<float>::max()));
        }
        if (!engine::is_valid_ray(r))
            return i;
    }
    return end;
}

template <class F>
char* put(char* p, F v) {
    std::memcpy(p, &v, sizeof v);
    return p + sizeof v;
}

template <class F>
char* put_hit(char* p, const engine::Hit& h) {
    if (!h.valid()) {
        p = put<F>(p, std::numeric_limits<F>::infinity());
        p = put<std::uint32_t>(p, engine::kInvalidId);
        p = put<std::uint32_t>(p, engine::kInvalidId);
        std::memset(p, 0, 5 * sizeof(F));
        return p + 5 * sizeof(F);
    }
    p = put<F>(p, static_cast<F>(h.t));
    p = put<std::uint32_t>(p, h.object);
    p = put<std::uint32_t>(p, h.primitive);
    p = put<F>(p, static_cast<F>(h.u));
    p = put<F>(p, static_cast<F>(h.v));
    p = put<F>(p, static_cast<F>(h.normal.x));
    p = put<F>(p, static_cast<F>(h.normal.y));
    return put<F>(p, static_cast<F>(h.normal.z));
}

/// Bytes of one hit record with floats of type F (hit_record_bytes of its dtype).
template <class F>
constexpr std::size_t kHitRecord = 2 * sizeof(std::uint32_t) + 6 * sizeof(F);
static_assert(kHitRecord<float> == 32 && kHitRecord<double> == 56,
              "hit_record_bytes (binary_codec.h) must agree");

/// closest/any answers hits[begin, end) at out + begin × record (closest: hit records; any: u32).
template <class F>
void encode_range_as(const engine::Hit* hits, engine::Mode mode, std::size_t begin, std::size_t end,
                     char* out) {
    if (mode == engine::Mode::closest) {
        char* p = out + begin * kHitRecord<F>;
        for (std::size_t i = begin; i < end; ++i)
            p = put_hit<F>(p, hits[i]);
        return;
    }
    char* p = out + begin * sizeof(std::uint32_t);
    for (std::size_t i = begin; i < end; ++i)
        p = put<std::uint32_t>(p, hits[i].valid() ? 1u : 0u);
}

template <class F>
void encode_as(const engine::QueryResult& r, engine::Mode mode, std::size_t n, std::string& out) {
    constexpr std::size_t rec = kHitRecord<F>;
    switch (mode) {
        case engine::Mode::closest:
        case engine::Mode::any: {
            out.resize(n * (mode == engine::Mode::closest ? rec : sizeof(std::uint32_t)));
            for_blocks(n, [&](std::size_t b, std::size_t e) {
                encode_range_as<F>(r.hits.data(), mode, b, e, out.data());
            });
            break;
        }
        case engine::Mode::count: {
            out.resize(n * sizeof(std::uint32_t));
            char* p = out.data();
            for (std::size_t i = 0; i < n; ++i)
                p = put<std::uint32_t>(p, r.counts[i]);
            break;
        }
        case engine::Mode::all: {
            out.resize(n * sizeof(std::uint32_t) + r.hits.size() * rec);
            char* p = out.data();
            for (std::size_t i = 0; i < n; ++i) {
                p = put<std::uint32_t>(p, r.offsets[i + 1] - r.offsets[i]);
                for (std::uint32_t k = r.offsets[i]; k < r.offsets[i + 1]; ++k) {
                    p = put_hit<F>(p, r.hits[k]);
                }
            }
            break;
        }
    }
}

}  // namespace

Dtype parse_dtype(const std::string& s) {
    if (s == "float32")
        return Dtype::float32;
    if (s == "float64")
        return Dtype::float64;
    throw ApiError(ErrorCode::invalid_request,
                   "dtype must be float32 or float64, got \"" + s + "\"", "dtype");
}

std::size_t ray_count(std::size_t bytes, Dtype dtype, std::size_t max_rays) {
    const std::size_t rec = ray_record_bytes(dtype);
    if (bytes % rec != 0) {
        throw ApiError(ErrorCode::invalid_ray, "body of " + std::to_string(bytes) +
                                                   " bytes is not a whole number of " +
                                                   std::to_string(rec) + "-byte ray records");
    }
    const std::size_t n = bytes / rec;
    if (n > max_rays) {
        throw ApiError(ErrorCode::too_large, std::to_string(n) + " rays is over the limit of " +
                                                 std::to_string(max_rays) + " per request");
    }
    return n;
}

std::size_t decode_ray_range(std::string_view body, Dtype dtype, std::size_t begin, std::size_t end,
                             engine::Ray* out) {
    return dtype == Dtype::float32 ? decode_as<float>(body, begin, end, out)
                                   : decode_as<double>(body, begin, end, out);
}

std::size_t first_bad_ray(std::string_view body, Dtype dtype, std::size_t begin, std::size_t end) {
    // In pieces through a small buffer that stays in L1.
    constexpr std::size_t kPiece = 128;
    engine::Ray rays[kPiece];
    for (std::size_t b = begin; b < end; b += kPiece) {
        const std::size_t e = std::min(end, b + kPiece);
        if (const std::size_t bad = decode_ray_range(body, dtype, b, e, rays); bad < e)
            return bad;
    }
    return end;
}

engine::Ray ray_at(std::string_view body, Dtype dtype, std::size_t index) {
    engine::Ray ray;
    decode_ray_range(body, dtype, index, index + 1, &ray);
    return ray;
}

void lower_to(std::atomic<std::size_t>& first_bad, std::size_t i) {
    std::size_t cur = first_bad.load();
    while (i < cur && !first_bad.compare_exchange_weak(cur, i)) {
    }
}

void throw_invalid_ray(const engine::Ray& ray, std::size_t index) {
    const engine::Status st = engine::validate_ray(ray, index);
    throw ApiError(ErrorCode::invalid_ray, st.message, "/rays/" + std::to_string(index));
}

void decode_rays(std::string_view body, Dtype dtype, std::size_t max_rays,
                 std::vector<engine::Ray>& rays) {
    const std::size_t n = ray_count(body.size(), dtype, max_rays);
    rays.resize(n);
    // Decoded and checked in parallel blocks; the error names the lowest bad index, as a
    // serial scan would.
    std::atomic<std::size_t> first_bad{n};
    for_blocks(n, [&](std::size_t b, std::size_t e) {
        const std::size_t i = decode_ray_range(body, dtype, b, e, rays.data() + b);
        if (i < e)
            lower_to(first_bad, i);
    });
    if (const std::size_t i = first_bad.load(); i < n)
        throw_invalid_ray(rays[i], i);
}

std::size_t answer_record_bytes(engine::Mode mode, Dtype dtype) {
    return mode == engine::Mode::closest ? hit_record_bytes(dtype) : sizeof(std::uint32_t);
}

void encode_answers(const engine::Hit* hits, engine::Mode mode, Dtype dtype, std::size_t begin,
                    std::size_t end, char* out) {
    if (dtype == Dtype::float32) {
        encode_range_as<float>(hits, mode, begin, end, out);
    } else {
        encode_range_as<double>(hits, mode, begin, end, out);
    }
}

void encode_results(const engine::QueryResult& result, engine::Mode mode, Dtype dtype,
                    std::size_t ray_count, std::string& out) {
    if (dtype == Dtype::float32) {
        encode_as<float>(result, mode, ray_count, out);
    } else {
        encode_as<double>(result, mode, ray_count, out);
    }
}

}  // namespace raycastd::server
