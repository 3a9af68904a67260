// The binary ray records of intersect (server/schema/binary_codec.h). The first byte picks the
// dtype (bit 0: float32 or float64) and the ray limit (1 + the other bits); the rest is the
// body. The codec's entry points must agree with each other and with the engine's ray rules:
//   * ray_count refuses exactly a partial record (invalid_ray) or too many rays (too_large);
//   * decode_rays throws invalid_ray, at /rays/<i>, exactly when first_bad_ray finds i;
//   * decode_ray_range over any split, ray_at and decode_rays decode the same bits;
//   * a decoded ray is valid exactly when validate_ray says so, and a valid one encodes back
//     to its record's bytes.

#include <cstring>
#include <limits>
#include <type_traits>
#include <vector>

#include "engine/query/intersect.h"
#include "server/api_error.h"
#include "server/schema/binary_codec.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

using namespace raycastd;
using server::Dtype;

bool same_bits(const engine::Ray& a, const engine::Ray& b) {
    return std::memcmp(&a, &b, sizeof(engine::Ray)) == 0;
}

template <class F>
bool encodes_back(const engine::Ray& r, const char* record) {
    F v[8] = {F(r.origin.x),    F(r.origin.y),    F(r.origin.z), F(r.direction.x),
              F(r.direction.y), F(r.direction.z), F(r.tmin),     F(r.tmax)};
    F want[8];
    std::memcpy(want, record, sizeof want);
    if constexpr (std::is_same_v<F, float>) {
        // A float32 ray ends at FLT_MAX (binary_codec.cpp): +inf bounds decode to it.
        for (int k = 6; k < 8; ++k) {
            if (want[k] == std::numeric_limits<float>::infinity())
                want[k] = std::numeric_limits<float>::max();
        }
    }
    return std::memcmp(v, want, sizeof v) == 0;
}

/// ray_count's answer, or the code it threw.
std::size_t count_or_fail(std::string_view body, Dtype dtype, std::size_t max_rays) {
    const std::size_t rec = server::ray_record_bytes(dtype);
    try {
        const std::size_t n = server::ray_count(body.size(), dtype, max_rays);
        if (body.size() % rec != 0 || n != body.size() / rec || n > max_rays)
            fuzz::fail("ray_count accepted a body it should refuse");
        return n;
    } catch (const server::ApiError& e) {
        const bool partial = body.size() % rec != 0;
        const server::ErrorCode want =
            partial ? server::ErrorCode::invalid_ray : server::ErrorCode::too_large;
        if (e.code != want || (!partial && body.size() / rec <= max_rays))
            fuzz::fail(std::string("ray_count threw ") + e.what());
        return SIZE_MAX;
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0)
        return 0;
    const Dtype dtype = (data[0] & 1) ? Dtype::float64 : Dtype::float32;
    const std::size_t max_rays = 1 + (data[0] >> 1);
    const std::string_view body = fuzz::bytes_of(data + 1, size - 1);
    const std::size_t n = count_or_fail(body, dtype, max_rays);
    if (n == SIZE_MAX)
        return 0;
    const std::size_t rec = server::ray_record_bytes(dtype);

    const std::size_t first_bad = server::first_bad_ray(body, dtype, 0, n);
    std::vector<engine::Ray> rays;
    try {
        server::decode_rays(body, dtype, max_rays, rays);
        if (first_bad != n)
            fuzz::fail("decode_rays accepted ray " + std::to_string(first_bad));
    } catch (const server::ApiError& e) {
        if (e.code != server::ErrorCode::invalid_ray || first_bad == n ||
            e.path != "/rays/" + std::to_string(first_bad)) {
            fuzz::fail(std::string("decode_rays threw ") + e.what() + " at " + e.path +
                       "; first_bad_ray: " + std::to_string(first_bad));
        }
    }

    // The same records decoded in two ranges split at every ray count (n is at most 128).
    std::vector<engine::Ray> pieces(n);
    for (std::size_t split = 0; split <= n; ++split) {
        const std::size_t a = server::decode_ray_range(body, dtype, 0, split, pieces.data());
        const std::size_t b =
            server::decode_ray_range(body, dtype, split, n, pieces.data() + split);
        const std::size_t bad = a < split ? a : b;
        if (bad != first_bad)
            fuzz::fail("decode_ray_range split at " + std::to_string(split) + " found ray " +
                       std::to_string(bad) + ", first_bad_ray " + std::to_string(first_bad));
        if (server::first_bad_ray(body, dtype, split, n) != (first_bad >= split ? first_bad : b))
            fuzz::fail("first_bad_ray from " + std::to_string(split) + " disagrees");
    }

    for (std::size_t i = 0; i <= first_bad && i < n; ++i) {
        const engine::Ray r = server::ray_at(body, dtype, i);
        if (first_bad == n && !same_bits(r, rays[i]))
            fuzz::fail("ray_at and decode_rays differ at ray " + std::to_string(i));
        const bool valid = engine::is_valid_ray(r);
        if (valid != engine::validate_ray(r, i).ok())
            fuzz::fail("is_valid_ray and validate_ray disagree on ray " + std::to_string(i));
        if (valid != (i < first_bad))
            fuzz::fail("first_bad_ray misplaced at ray " + std::to_string(i));
        const char* record = body.data() + i * rec;
        if (valid && !(dtype == Dtype::float32 ? encodes_back<float>(r, record)
                                               : encodes_back<double>(r, record)))
            fuzz::fail("ray " + std::to_string(i) + " does not encode back to its record");
    }
    return 0;
}
