#pragma once
// The binary form of intersect (docs/api.md): packed little-endian records, no header, no padding.
//   request:  N × {ox oy oz dx dy dz tmin tmax}            (8 floats of dtype)
//   closest:  N × {t, object u32, primitive u32, u, v, nx, ny, nz}
//             (floats of dtype; a miss is t = +inf, object = primitive = 0xFFFFFFFF, rest 0)
//   any:      N × u32 (1 hit, 0 miss)
//   count:    N × u32 (crossings, shared edges once)
//   all:      per ray, u32 n followed by n closest-records, in ray order
// Normals are written as zeros when the request asks for fields without them (?fields=...).

#include <atomic>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "engine/query/query_result.h"

namespace raycastd::server {

enum class Dtype { float32, float64 };

/// Bytes of one request record.
inline std::size_t ray_record_bytes(Dtype d) {
    return d == Dtype::float32 ? 32 : 64;
}
/// Bytes of one hit record.
inline std::size_t hit_record_bytes(Dtype d) {
    return d == Dtype::float32 ? 32 : 56;
}

Dtype parse_dtype(const std::string& s);

/// The number of ray records in a body of `bytes` bytes: invalid_ray when that is not a whole
/// number of records, too_large over max_rays (the errors decode_rays gives).
std::size_t ray_count(std::size_t bytes, Dtype dtype, std::size_t max_rays);

/// Decodes records [begin, end) of `body` into out[0 .. end-begin) and checks them: the lowest
/// index (in the body) of a ray that breaks the API's rules, or `end`. Records after a bad one
/// are not decoded.
std::size_t decode_ray_range(std::string_view body, Dtype dtype, std::size_t begin, std::size_t end,
                             engine::Ray* out);

/// The lowest index in [begin, end) of a record of `body` that breaks the API's rules, or `end`
/// (decode_ray_range's check, without keeping the rays).
std::size_t first_bad_ray(std::string_view body, Dtype dtype, std::size_t begin, std::size_t end);

/// Ray `index` of `body`, decoded.
engine::Ray ray_at(std::string_view body, Dtype dtype, std::size_t index);

/// Lowers `first_bad` to `i` if `i` is lower: blocks checked in parallel report the lowest bad
/// index, as a serial scan would.
void lower_to(std::atomic<std::size_t>& first_bad, std::size_t i);

/// Throws invalid_ray naming ray `index` (a ray decode_ray_range reported) and what is wrong.
[[noreturn]] void throw_invalid_ray(const engine::Ray& ray, std::size_t index);

/// Decodes the body into `rays` (capacity reused). invalid_ray for a length that is not a whole
/// number of records, and for a NaN/Inf origin or direction, a zero direction, NaN or inverted
/// tmin/tmax (tmin may be −inf, tmax +inf), naming the ray index; too_large over max_rays.
void decode_rays(std::string_view body, Dtype dtype, std::size_t max_rays,
                 std::vector<engine::Ray>& rays);

/// Bytes of one answer record of closest (a hit record) or any (a u32).
std::size_t answer_record_bytes(engine::Mode mode, Dtype dtype);

/// Encodes closest or any answers hits[begin, end) at out + begin × answer_record_bytes (the
/// buffer sized for the whole batch): a batch can be encoded piece by piece.
void encode_answers(const engine::Hit* hits, engine::Mode mode, Dtype dtype, std::size_t begin,
                    std::size_t end, char* out);

/// Encodes the answers of `mode` into `out` (cleared; capacity reused).
void encode_results(const engine::QueryResult& result, engine::Mode mode, Dtype dtype,
                    std::size_t ray_count, std::string& out);

}  // namespace raycastd::server
