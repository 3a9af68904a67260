#include "engine/accel/embree/exact_bvh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <new>

#include <immintrin.h>

#include "engine/accel/embree/impl.h"
#include "engine/geometry/target_clones.h"
#include "engine/mapped_allocator.h"

namespace raycastd::engine::embree {

// ---------------------------------------------------------------------------------------------
// The box test.

namespace {

constexpr float kDown = 1.0f - 3.0f * std::numeric_limits<float>::epsilon();  // exact_bvh.h
constexpr float kUp = 1.0f + 3.0f * std::numeric_limits<float>::epsilon();

/// The slab test of eight boxes (their planes lo[axis], hi[axis]), as ExactBvh::meets says.
[[gnu::target("avx")]] inline unsigned slabs_avx(const __m256 lo[3], const __m256 hi[3],
                                                 const ExactBvh::Lanes& r, float tnear, float tfar,
                                                 float near[8]) {
    __m256 tn = _mm256_set1_ps(tnear), tf = _mm256_set1_ps(tfar);
    for (int k = 0; k < 3; ++k) {
        const __m256 o = _mm256_set1_ps(r.org[k]), inv = _mm256_set1_ps(r.inv[k]);
        tn = _mm256_max_ps(tn, _mm256_mul_ps(_mm256_sub_ps(r.neg[k] ? hi[k] : lo[k], o), inv));
        tf = _mm256_min_ps(tf, _mm256_mul_ps(_mm256_sub_ps(r.neg[k] ? lo[k] : hi[k], o), inv));
    }
    tn = _mm256_mul_ps(tn, _mm256_set1_ps(kDown));
    _mm256_store_ps(near, tn);
    const __m256 ok = _mm256_cmp_ps(tn, _mm256_mul_ps(tf, _mm256_set1_ps(kUp)), _CMP_LE_OQ);
    return static_cast<unsigned>(_mm256_movemask_ps(ok));
}

/// Four lanes of slabs_avx (from `lane` on: near + lane), with SSE's four-wide forms of the same
/// operations.
inline unsigned slabs_sse(const __m128 lo[3], const __m128 hi[3], const ExactBvh::Lanes& r,
                          float tnear, float tfar, float near[8], int lane) {
    __m128 tn = _mm_set1_ps(tnear), tf = _mm_set1_ps(tfar);
    for (int k = 0; k < 3; ++k) {
        const __m128 o = _mm_set1_ps(r.org[k]), inv = _mm_set1_ps(r.inv[k]);
        tn = _mm_max_ps(tn, _mm_mul_ps(_mm_sub_ps(r.neg[k] ? hi[k] : lo[k], o), inv));
        tf = _mm_min_ps(tf, _mm_mul_ps(_mm_sub_ps(r.neg[k] ? lo[k] : hi[k], o), inv));
    }
    tn = _mm_mul_ps(tn, _mm_set1_ps(kDown));
    _mm_store_ps(near + lane, tn);
    return static_cast<unsigned>(
        _mm_movemask_ps(_mm_cmple_ps(tn, _mm_mul_ps(tf, _mm_set1_ps(kUp)))));
}

/// Eight lanes' planes of one axis (`q`: their bytes): origin + q·scale, a product and a sum
/// in float as quantize() checked them.
[[gnu::target("avx")]] inline __m256 planes_avx(const std::uint8_t* q, float origin, float scale) {
    const __m128i b = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(q));
    const __m128i first = _mm_cvtepu8_epi32(b), second = _mm_cvtepu8_epi32(_mm_srli_si128(b, 4));
    const __m256 f =
        _mm256_cvtepi32_ps(_mm256_insertf128_si256(_mm256_castsi128_si256(first), second, 1));
    return _mm256_add_ps(_mm256_set1_ps(origin), _mm256_mul_ps(f, _mm256_set1_ps(scale)));
}

/// Four lanes' planes from `lane` on, with SSE2 alone (a processor without AVX may lack SSE4.1).
inline __m128 planes_sse(const std::uint8_t* q, int lane, float origin, float scale) {
    std::int32_t four;
    std::memcpy(&four, q + lane, sizeof four);
    const __m128i z = _mm_setzero_si128();
    const __m128i w = _mm_unpacklo_epi16(_mm_unpacklo_epi8(_mm_cvtsi32_si128(four), z), z);
    return _mm_add_ps(_mm_set1_ps(origin), _mm_mul_ps(_mm_cvtepi32_ps(w), _mm_set1_ps(scale)));
}

[[gnu::target("avx")]] unsigned meets_avx(const ExactBvh::Node& n, const ExactBvh::Lanes& r,
                                          float tnear, float tfar, float near[8]) {
    __m256 lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
        lo[k] = _mm256_load_ps(n.lo[k]);
        hi[k] = _mm256_load_ps(n.hi[k]);
    }
    return slabs_avx(lo, hi, r, tnear, tfar, near);
}

/// slabs_sse on both halves of a node, `planes(lane, lo, hi)` giving each half's planes.
template <class Planes>
unsigned halves_sse(Planes planes, const ExactBvh::Lanes& r, float tnear, float tfar,
                    float near[8]) {
    unsigned mask = 0;
    for (int lane = 0; lane < ExactBvh::kWidth; lane += 4) {
        __m128 lo[3], hi[3];
        planes(lane, lo, hi);
        mask |= slabs_sse(lo, hi, r, tnear, tfar, near, lane) << lane;
    }
    return mask;
}

unsigned meets_sse(const ExactBvh::Node& n, const ExactBvh::Lanes& r, float tnear, float tfar,
                   float near[8]) {
    const auto planes = [&n](int lane, __m128 lo[3], __m128 hi[3]) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = _mm_load_ps(n.lo[k] + lane);
            hi[k] = _mm_load_ps(n.hi[k] + lane);
        }
    };
    return halves_sse(planes, r, tnear, tfar, near);
}

[[gnu::target("avx")]] unsigned meets_avx(const ExactBvh::QNode& n, const ExactBvh::Lanes& r,
                                          float tnear, float tfar, float near[8]) {
    __m256 lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
        lo[k] = planes_avx(n.lo[k], n.origin[k], n.scale[k]);
        hi[k] = planes_avx(n.hi[k], n.origin[k], n.scale[k]);
    }
    return slabs_avx(lo, hi, r, tnear, tfar, near) & ~static_cast<unsigned>(n.empty);
}

unsigned meets_sse(const ExactBvh::QNode& n, const ExactBvh::Lanes& r, float tnear, float tfar,
                   float near[8]) {
    const auto planes = [&n](int lane, __m128 lo[3], __m128 hi[3]) {
        for (int k = 0; k < 3; ++k) {
            lo[k] = planes_sse(n.lo[k], lane, n.origin[k], n.scale[k]);
            hi[k] = planes_sse(n.hi[k], lane, n.origin[k], n.scale[k]);
        }
    };
    return halves_sse(planes, r, tnear, tfar, near) & ~static_cast<unsigned>(n.empty);
}

/// A plane as the walk forms it (planes_avx, planes_sse).
float plane(float origin, std::uint8_t q, float scale) {
    return origin + static_cast<float>(q) * scale;
}

}  // namespace

unsigned ExactBvh::meets(const Node& n, const Lanes& r, float tnear, float tfar, float near[8],
                         bool avx) {
    return avx ? meets_avx(n, r, tnear, tfar, near) : meets_sse(n, r, tnear, tfar, near);
}

unsigned ExactBvh::meets(const QNode& n, const Lanes& r, float tnear, float tfar, float near[8],
                         bool avx) {
    return avx ? meets_avx(n, r, tnear, tfar, near) : meets_sse(n, r, tnear, tfar, near);
}

bool ExactBvh::quantize(const Node& n, QNode& q) {
    q = QNode{};
    q.empty = 0;
    for (int k = 0; k < kWidth; ++k) {
        q.child[k] = n.child[k];
        if (!(n.lo[0][k] <= n.hi[0][k] && n.lo[1][k] <= n.hi[1][k] && n.lo[2][k] <= n.hi[2][k]))
            q.empty = static_cast<std::uint8_t>(q.empty | 1u << k);
    }
    for (int a = 0; a < 3; ++a) {
        float lo = std::numeric_limits<float>::infinity(), hi = -lo;
        for (int k = 0; k < kWidth; ++k)
            if (!(q.empty >> k & 1u)) {
                lo = std::min(lo, n.lo[a][k]);
                hi = std::max(hi, n.hi[a][k]);
            }
        if (q.empty == 0xFF) {  // no child: no box to give
            lo = hi = 0.0f;
        }
        if (!std::isfinite(lo) || !std::isfinite(hi))
            return false;
        // The step: the extent over 255, raised until the last byte reaches the top plane.
        float scale = (hi - lo) / 255.0f;
        if (!std::isfinite(scale))
            return false;
        while (plane(lo, 255, scale) < hi)
            scale = std::nextafter(scale, std::numeric_limits<float>::infinity());
        q.origin[a] = lo;
        q.scale[a] = scale;
        // A byte's first guess for a plane x, and the plane a byte gives.
        const auto guess = [&](float x) {
            const float g = scale > 0.0f ? (x - lo) / scale : 0.0f;
            return static_cast<int>(std::min(std::max(g, 0.0f), 255.0f));
        };
        const auto at = [&](int byte) { return plane(lo, static_cast<std::uint8_t>(byte), scale); };
        for (int k = 0; k < kWidth; ++k) {
            if (q.empty >> k & 1u) {  // no box: bytes that give none, and the lane masked out
                q.lo[a][k] = 255;
                q.hi[a][k] = 0;
                continue;
            }
            // The guess, then stepped outward until the plane contains the box's (byte 0 is the
            // origin itself, byte 255 at or beyond the top: above).
            int b = guess(n.lo[a][k]);
            while (b > 0 && at(b) > n.lo[a][k])
                --b;
            while (b < 255 && at(b + 1) <= n.lo[a][k])
                ++b;
            int t = guess(n.hi[a][k]);
            while (t < 255 && at(t) < n.hi[a][k])
                ++t;
            while (t > 0 && at(t - 1) >= n.hi[a][k])
                --t;
            q.lo[a][k] = static_cast<std::uint8_t>(b);
            q.hi[a][k] = static_cast<std::uint8_t>(t);
        }
    }
    return true;
}

void ExactBvh::dequantize(const QNode& q, int k, float lo[3], float hi[3]) {
    for (int a = 0; a < 3; ++a) {
        lo[a] = plane(q.origin[a], q.lo[a][k], q.scale[a]);
        hi[a] = plane(q.origin[a], q.hi[a][k], q.scale[a]);
    }
}

// The pre-test of a leaf, for the walks compiled with AVX (which inline woop_misses_avx into
// themselves: `flatten`) and without.
template <bool avx>
bool ExactBvh::pretest_misses(std::uint32_t object, std::uint32_t prim, const WoopRay* woop) const {
    const TriangleMesh* mesh = woop ? meshes_[object] : nullptr;
    if (!mesh)
        return false;
    const auto& t = mesh->triangles[prim];
    const Vec3d &pa = mesh->positions[t[0]], &pb = mesh->positions[t[1]],
                &pc = mesh->positions[t[2]];
    if constexpr (avx)
        return woop_misses_avx(pa, pb, pc, *woop);
    else
        return woop_misses(Triangle{pa, pb, pc}, *woop);
}

// Inlined by force: without it, GCC 12's walk_avx held neither the node prefetches nor a call
// to prefetch_nodes (its object code, checked when the prefetch was added); with it, both walks
// hold them all.
[[gnu::always_inline]] inline void ExactBvh::prefetch_nodes(const std::uint32_t* child,
                                                            unsigned mask) const {
    for (; mask; mask &= mask - 1) {
        const std::uint32_t c = child[__builtin_ctz(mask)];
        if (c & kLeafBit)
            continue;
        // Every cache line of the node: the box test reads all of them.
        if (c & kBottomBit) {
            static_assert(sizeof(QNode) == 2 * 64);
            const char* at = reinterpret_cast<const char*>(&bottom_[c & ~kBottomBit]);
            __builtin_prefetch(at);
            __builtin_prefetch(at + 64);
        } else {
            static_assert(sizeof(Node) > 3 * 64 && sizeof(Node) <= 4 * 64);
            const char* at = reinterpret_cast<const char*>(&nodes_[c]);
            __builtin_prefetch(at);
            __builtin_prefetch(at + 64);
            __builtin_prefetch(at + 128);
            __builtin_prefetch(at + 192);
        }
    }
}

[[gnu::always_inline]] inline void ExactBvh::prefetch_leaves(const std::uint32_t* child,
                                                             unsigned mask) const {
    for (; mask; mask &= mask - 1) {
        const std::uint32_t g = child[__builtin_ctz(mask)] & ~kLeafBit;
        const std::uint32_t object = object_of(g);
        if (const TriangleMesh* mesh = meshes_[object])
            __builtin_prefetch(&mesh->triangles[g - first_[object]]);
    }
}

template <bool ordered, bool avx>
void ExactBvh::walk_in_order(const Lanes& r, float tnear, float tfar, VisitFn fn, void* visit,
                             const WoopRay* woop) const {
    Entry stack[kStack];
    int sp = 0;
    std::uint32_t code = root_;
    for (;;) {
        // Down: into the nearest child the ray meets, the others pushed, the nearest on top.
        while (!(code & kLeafBit)) {
            alignas(32) float near[kWidth];
            unsigned mask;
            const std::uint32_t* child;
            // Where several children are met, the walk takes the nearest at once and comes back
            // to the others after it: what it reads of each first is asked for now (the nearest
            // too, which is known only once they are sorted below), and arrives meanwhile
            // (docs/numerics.md: B's random rays, whose walk reads ~51 MB, more than the 32 MB
            // cache, 0.48–0.49 → 0.55–0.58× rtcIntersect1), where the tree is too large to stay
            // in the cache (kPrefetchFromBytes).
            if (code & kBottomBit) {
                const QNode& n = bottom_[code & ~kBottomBit];
                mask =
                    avx ? meets_avx(n, r, tnear, tfar, near) : meets_sse(n, r, tnear, tfar, near);
                child = n.child;
                if (prefetch_rows_ && (mask & (mask - 1)))
                    prefetch_leaves(child, mask);
            } else {
                const Node& n = nodes_[code];
                mask =
                    avx ? meets_avx(n, r, tnear, tfar, near) : meets_sse(n, r, tnear, tfar, near);
                child = n.child;
                if (prefetch_nodes_ && (mask & (mask - 1)))
                    prefetch_nodes(child, mask);
            }
            if (!mask) {
                code = kNoChild;
                break;
            }
            int k = __builtin_ctz(mask);
            mask &= mask - 1;
            if (!mask) {  // one child: the common case, no stack
                code = child[k];
                continue;
            }
            const int base = sp;
            for (;;) {
                const Entry x{child[k], near[k]};
                int i = sp++;
                if (ordered) {  // insertion: decreasing tnear from the base up
                    while (i > base && stack[i - 1].tnear < x.tnear) {
                        stack[i] = stack[i - 1];
                        --i;
                    }
                }
                stack[i] = x;
                if (!mask)
                    break;
                k = __builtin_ctz(mask);
                mask &= mask - 1;
            }
            code = stack[--sp].code;
        }
        if (code != kNoChild) {  // a primitive
            const std::uint32_t g = code & ~kLeafBit;
            const std::uint32_t object = object_of(g);
            const std::uint32_t prim = g - first_[object];
            if (!pretest_misses<avx>(object, prim, woop) && !fn(visit, object, prim, tfar))
                return;
        }
        // Up: the nearest pushed entry that no hit found since has culled.
        for (;;) {
            if (sp == 0)
                return;
            const Entry& e = stack[--sp];
            if (e.tnear <= tfar * kUp) {
                code = e.code;
                break;
            }
        }
    }
}

// The walk compiled twice, for AVX and without, each with its box test inlined: `flatten` inlines
// walk_in_order and what it calls into the entry point, whose target then admits meets_avx. (As
// a call, the box test, its ray loaded from memory each time, had been 30% of an exact query's
// time on A's camera rays: perf, 2026-12-06.) Clang 14's flatten inlines one level only
// (llvm/llvm-project#60689): its sanitizer builds still call the box test, with the same answers.
[[gnu::target("avx"), gnu::flatten]] void ExactBvh::walk_avx(const Lanes& r, float tnear,
                                                             float tfar, bool ordered, VisitFn fn,
                                                             void* visit,
                                                             const WoopRay* woop) const {
    if (ordered)
        walk_in_order<true, true>(r, tnear, tfar, fn, visit, woop);
    else
        walk_in_order<false, true>(r, tnear, tfar, fn, visit, woop);
}

[[gnu::flatten]] void ExactBvh::walk_sse(const Lanes& r, float tnear, float tfar, bool ordered,
                                         VisitFn fn, void* visit, const WoopRay* woop) const {
    if (ordered)
        walk_in_order<true, false>(r, tnear, tfar, fn, visit, woop);
    else
        walk_in_order<false, false>(r, tnear, tfar, fn, visit, woop);
}

void ExactBvh::walk(const Lanes& r, float tnear, float tfar, bool ordered, VisitFn fn, void* visit,
                    const WoopRay* woop) const {
    if (cpu_has_avx())
        walk_avx(r, tnear, tfar, ordered, fn, visit, woop);
    else
        walk_sse(r, tnear, tfar, ordered, fn, visit, woop);
}

void ExactBvh::add_lane(Packet& p, int k, const Lanes& r, float tnear, float tfar,
                        const WoopRay* woop) {
    for (int a = 0; a < 3; ++a)
        p.neg[a] = r.neg[a];  // the same in every lane (runs_with)
    for (int a = 0; a < 3; ++a) {
        p.org[a][k] = r.org[a];
        p.inv[a][k] = r.inv[a];
    }
    p.tnear[k] = tnear;
    p.tfar[k] = tfar;
    p.woop[k] = woop;
    p.active |= 1u << k;
}

std::uint32_t ExactBvh::object_of(std::uint32_t g) const {
    // The last object whose first primitive is not beyond g (one compare for a single mesh;
    // objects without primitives are passed over, sharing the next one's first).
    return first_.size() == 2
               ? 0u
               : static_cast<std::uint32_t>(std::upper_bound(first_.begin(), first_.end(), g) -
                                            first_.begin()) -
                     1u;
}

namespace {

/// A child's box against every lane of a packet: slabs_avx's operations with the lanes across
/// rays instead of boxes (the box's planes broadcast, each lane's origin, reciprocal and range
/// its own), so each lane's answer and entry distance are those slabs_avx gives its ray.
[[gnu::target("avx")]] inline unsigned packet_slabs(const float lo[3], const float hi[3],
                                                    const ExactBvh::Packet& p, __m256 tfar,
                                                    __m256& tn) {
    tn = _mm256_load_ps(p.tnear);
    __m256 tf = tfar;
    for (int k = 0; k < 3; ++k) {
        const __m256 o = _mm256_load_ps(p.org[k]), inv = _mm256_load_ps(p.inv[k]);
        const __m256 near = _mm256_set1_ps(p.neg[k] ? hi[k] : lo[k]);
        const __m256 far = _mm256_set1_ps(p.neg[k] ? lo[k] : hi[k]);
        tn = _mm256_max_ps(tn, _mm256_mul_ps(_mm256_sub_ps(near, o), inv));
        tf = _mm256_min_ps(tf, _mm256_mul_ps(_mm256_sub_ps(far, o), inv));
    }
    tn = _mm256_mul_ps(tn, _mm256_set1_ps(kDown));
    const __m256 ok = _mm256_cmp_ps(tn, _mm256_mul_ps(tf, _mm256_set1_ps(kUp)), _CMP_LE_OQ);
    return static_cast<unsigned>(_mm256_movemask_ps(ok));
}

/// The least of tn's lanes in `mask`: the order a packet's children are walked in.
[[gnu::target("avx")]] inline float least_lane(__m256 tn, unsigned mask) {
    alignas(32) float v[8];
    _mm256_store_ps(v, tn);
    float least = std::numeric_limits<float>::infinity();
    for (; mask; mask &= mask - 1)
        least = std::min(least, v[__builtin_ctz(mask)]);
    return least;
}

}  // namespace

[[gnu::target("avx"), gnu::flatten]] void ExactBvh::walk_packet(Packet& p, LaneVisitFn fn,
                                                                void* visit) const {
    if (root_ == kNoChild || !p.active)
        return;
    // A child met by some lanes: which, their entry distances, and its place in the order.
    struct alignas(32) PacketEntry {
        float tnear[kWidth];
        std::uint32_t code;
        unsigned mask;
        float key;
    };
    PacketEntry stack[kStack];
    int sp = 0;
    std::uint32_t code = root_;
    unsigned mask = p.active;
    const auto offer = [&](std::uint32_t leaf, unsigned lanes) {
        const std::uint32_t g = leaf & ~kLeafBit;
        const std::uint32_t object = object_of(g);
        const std::uint32_t prim = g - first_[object];
        for (; lanes; lanes &= lanes - 1) {
            const int k = __builtin_ctz(lanes);
            if (!pretest_misses<true>(object, prim, p.woop[k]) &&
                !fn(visit, k, object, prim, p.tfar[k]))
                p.active &= ~(1u << k);
        }
    };
    for (;;) {
        // Down: into the nearest child some lane meets, the others pushed, the nearest on top.
        while (!(code & kLeafBit)) {
            float lo[kWidth][3], hi[kWidth][3];
            const std::uint32_t* child;
            unsigned present = 0;
            if (code & kBottomBit) {
                const QNode& n = bottom_[code & ~kBottomBit];
                for (int k = 0; k < kWidth; ++k) {
                    if (n.empty >> k & 1u)
                        continue;
                    present |= 1u << k;
                    dequantize(n, k, lo[k], hi[k]);
                }
                child = n.child;
            } else {
                const Node& n = nodes_[code];
                for (int k = 0; k < kWidth; ++k) {
                    if (n.child[k] == kNoChild)
                        continue;
                    present |= 1u << k;
                    for (int a = 0; a < 3; ++a) {
                        lo[k][a] = n.lo[a][k];
                        hi[k][a] = n.hi[a][k];
                    }
                }
                child = n.child;
            }
            const __m256 tfar = _mm256_load_ps(p.tfar);
            const int base = sp;
            for (; present; present &= present - 1) {
                const int k = __builtin_ctz(present);
                __m256 tn;
                const unsigned met = packet_slabs(lo[k], hi[k], p, tfar, tn) & mask;
                if (!met)
                    continue;
                PacketEntry& e = stack[sp];
                _mm256_store_ps(e.tnear, tn);
                e.code = child[k];
                e.mask = met;
                e.key = least_lane(tn, met);
                // Insertion: decreasing key from the base up, the nearest on top.
                int i = sp++;
                while (i > base && stack[i - 1].key < stack[i].key) {
                    std::swap(stack[i - 1], stack[i]);
                    --i;
                }
            }
            if (sp == base) {
                code = kNoChild;
                break;
            }
            --sp;
            code = stack[sp].code;
            mask = stack[sp].mask;
        }
        if (code != kNoChild)
            offer(code, mask & p.active);
        // Up: the nearest pushed entry that some lane still needs, the lanes that a hit found
        // since has culled dropped.
        for (;;) {
            if (sp == 0 || !p.active)
                return;
            const PacketEntry& e = stack[--sp];
            const __m256 keep = _mm256_cmp_ps(
                _mm256_load_ps(e.tnear), _mm256_mul_ps(_mm256_load_ps(p.tfar), _mm256_set1_ps(kUp)),
                _CMP_LE_OQ);
            const unsigned m = e.mask & p.active & static_cast<unsigned>(_mm256_movemask_ps(keep));
            if (m) {
                code = e.code;
                mask = m;
                break;
            }
        }
    }
}

ExactBvh::Lanes ExactBvh::lanes_of(float ox, float oy, float oz, float dx, float dy, float dz) {
    const auto safe_rcp = [](float d) {
        constexpr float kMin = 1e-18f;  // exact_bvh.h
        return 1.0f / (std::abs(d) < kMin ? std::copysign(kMin, d) : d);
    };
    Lanes r{{ox, oy, oz}, {safe_rcp(dx), safe_rcp(dy), safe_rcp(dz)}, {}};
    for (int k = 0; k < 3; ++k)
        r.neg[k] = r.inv[k] < 0.0f;
    return r;
}

// ---------------------------------------------------------------------------------------------
// The build.

namespace {

/// A primitive while the tree is built: its box, its box's centre, its index among the scene's.
struct Item {
    FloatBox box;
    float centre[3];
    std::uint32_t index;
};

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr FloatBox kEmpty{{kInf, kInf, kInf}, {-kInf, -kInf, -kInf}};

void grow(FloatBox& b, const FloatBox& x) {
    for (int k = 0; k < 3; ++k) {
        b.lo[k] = std::min(b.lo[k], x.lo[k]);
        b.hi[k] = std::max(b.hi[k], x.hi[k]);
    }
}

FloatBox box_of(const Item* begin, const Item* end) {
    FloatBox b = kEmpty;
    for (const Item* i = begin; i != end; ++i)
        grow(b, i->box);
    return b;
}

/// Half the surface area of a box (SAH's weight); 0 for an empty one.
float half_area(const FloatBox& b) {
    const float x = b.hi[0] - b.lo[0], y = b.hi[1] - b.lo[1], z = b.hi[2] - b.lo[2];
    return x < 0.0f ? 0.0f : x * y + y * z + z * x;
}

/// The most items split() cuts after a multiple of kWidth (exact_bvh.h: the nodes at the bottom
/// full). One level more (cuts after multiples of kWidth² up to kWidth³ items) left the nodes
/// above them as sparse as before and took A's tree from 38.5 to 39.9 B a triangle.
constexpr std::ptrdiff_t kFew = ExactBvh::kWidth * ExactBvh::kWidth;

/// Splits items[begin, end) (at least two) in two, in place, and returns where the second part
/// starts (strictly inside): binned SAH over the centres on their longest axis (exact_bvh.h), or
/// with `median` the centres' median on that axis; the middle by index where the centres all
/// fall in one bin. A range of at most kFew items (and more than kWidth) is split after a multiple
/// of kWidth items, so that the nodes at the bottom of the tree take kWidth primitives each.
Item* split(Item* begin, Item* end, bool median) {
    FloatBox c = kEmpty;
    for (const Item* i = begin; i != end; ++i)
        for (int k = 0; k < 3; ++k) {
            c.lo[k] = std::min(c.lo[k], i->centre[k]);
            c.hi[k] = std::max(c.hi[k], i->centre[k]);
        }
    int axis = 0;
    for (int k = 1; k < 3; ++k)
        if (c.hi[k] - c.lo[k] > c.hi[axis] - c.lo[axis])
            axis = k;
    const float extent = c.hi[axis] - c.lo[axis];
    const std::ptrdiff_t items_n = end - begin;
    if (items_n <= kFew && items_n > ExactBvh::kWidth) {
        if (extent > 0.0f)
            std::sort(begin, end, [axis](const Item& x, const Item& y) {
                return x.centre[axis] < y.centre[axis];
            });
        // The boxes' union from the right, at each multiple of kWidth from the left.
        std::array<float, kFew / ExactBvh::kWidth> right_area{};
        FloatBox acc = kEmpty;
        for (std::ptrdiff_t i = items_n - 1; i >= ExactBvh::kWidth; --i) {
            grow(acc, begin[i].box);
            if (i % ExactBvh::kWidth == 0)
                right_area[i / ExactBvh::kWidth] = half_area(acc);
        }
        acc = kEmpty;
        std::ptrdiff_t best = ExactBvh::kWidth;
        float best_cost = kInf;
        for (std::ptrdiff_t i = 0; i + 1 < items_n; ++i) {
            grow(acc, begin[i].box);
            const std::ptrdiff_t left = i + 1;
            if (left % ExactBvh::kWidth != 0)
                continue;
            const float cost =
                half_area(acc) * static_cast<float>(left) +
                right_area[left / ExactBvh::kWidth] * static_cast<float>(items_n - left);
            if (cost < best_cost) {
                best_cost = cost;
                best = left;
            }
        }
        return begin + best;
    }
    Item* const mid = begin + (end - begin) / 2;
    if (!(extent > 0.0f))  // every centre the same: any split is as good
        return mid;
    if (median) {
        std::nth_element(begin, mid, end, [axis](const Item& x, const Item& y) {
            return x.centre[axis] < y.centre[axis];
        });
        return mid;
    }
    constexpr int kBins = 32;
    const float scale = kBins / extent;
    const float lo = c.lo[axis];
    const auto bin_of = [&](const Item& i) {
        const int b = static_cast<int>((i.centre[axis] - lo) * scale);
        return std::min(std::max(b, 0), kBins - 1);
    };
    std::array<FloatBox, kBins> box;
    std::array<std::size_t, kBins> count{};
    box.fill(kEmpty);
    for (const Item* i = begin; i != end; ++i) {
        const int b = bin_of(*i);
        grow(box[b], i->box);
        ++count[b];
    }
    // The cost of splitting after bin b: area(left)·|left| + area(right)·|right|.
    std::array<float, kBins> right_cost{};
    FloatBox acc = kEmpty;
    std::size_t n = 0;
    for (int b = kBins - 1; b > 0; --b) {
        grow(acc, box[b]);
        n += count[b];
        right_cost[b] = half_area(acc) * static_cast<float>(n);
    }
    const std::size_t total = static_cast<std::size_t>(end - begin);
    acc = kEmpty;
    n = 0;
    int best = -1;
    float best_cost = kInf;
    for (int b = 0; b + 1 < kBins; ++b) {
        grow(acc, box[b]);
        n += count[b];
        if (n == 0 || n == total)
            continue;
        const float cost = half_area(acc) * static_cast<float>(n) + right_cost[b + 1];
        if (cost < best_cost) {
            best_cost = cost;
            best = b;
        }
    }
    if (best < 0)  // one bin holds them all
        return mid;
    return std::partition(begin, end, [&](const Item& i) { return bin_of(i) <= best; });
}

}  // namespace

/// Builds the tree depth first into `nodes` (reserved beforehand: never reallocated), as Nodes
/// of float boxes; build_tree then quantizes them into the tree's QNodes.
struct ExactBvhBuilder {
    MappedVector<ExactBvh::Node>& nodes;

    /// The child code of items[begin, end) (depth: nodes above it).
    std::uint32_t build(Item* begin, Item* end, int depth) {
        const std::size_t n = static_cast<std::size_t>(end - begin);
        if (n == 1)
            return ExactBvh::kLeafBit | begin->index;
        const bool median = depth >= ExactBvh::kSahDepth;
        // Up to kWidth children: the range split in two, then again and again the child with
        // the largest surface area among those of more than kWidth primitives; once none is
        // left, children whose primitives fit in the node's free lanes become that many leaves,
        // the smallest first. What remains of at most kWidth primitives becomes a node of that
        // many leaves below, and split() cuts ranges of up to kWidth² primitives after multiples
        // of kWidth, so that those nodes are full. (Splitting the largest child down to single
        // primitives had left most nodes at the bottom with two to four leaves: 3.9 children a
        // node on A, 77 B a triangle.)
        Item* bounds[ExactBvh::kWidth + 1] = {begin, end};
        FloatBox box[ExactBvh::kWidth] = {box_of(begin, end)};
        int children = 1;
        const auto size_of = [&](int k) { return static_cast<int>(bounds[k + 1] - bounds[k]); };
        // Room for `add` more children after child `pick`: the ones after it move up.
        const auto make_room = [&](int pick, int add) {
            for (int k = children; k > pick; --k) {
                bounds[k + add] = bounds[k];
                box[k + add - 1] = box[k - 1];
            }
        };
        while (children < ExactBvh::kWidth) {
            int pick = -1;
            for (int k = 0; k < children; ++k)
                if (size_of(k) > ExactBvh::kWidth &&
                    (pick < 0 || half_area(box[k]) > half_area(box[pick])))
                    pick = k;
            if (pick >= 0) {  // split in two
                make_room(pick, 1);
                Item* const mid = split(bounds[pick], bounds[pick + 2], median);
                bounds[pick + 1] = mid;
                box[pick] = box_of(bounds[pick], mid);
                box[pick + 1] = box_of(mid, bounds[pick + 2]);
                ++children;
                continue;
            }
            for (int k = 0; k < children; ++k)
                if (size_of(k) > 1 && children - 1 + size_of(k) <= ExactBvh::kWidth &&
                    (pick < 0 || size_of(k) < size_of(pick)))
                    pick = k;
            if (pick < 0)
                break;
            const int size = size_of(pick), add = size - 1;  // every primitive a leaf of its own
            make_room(pick, add);
            for (int k = 0; k < size; ++k) {
                bounds[pick + k] = bounds[pick] + k;
                box[pick + k] = bounds[pick][k].box;
            }
            children += add;
        }
        const std::uint32_t index = static_cast<std::uint32_t>(nodes.size());
        nodes.emplace_back();
        std::uint32_t codes[ExactBvh::kWidth];
        for (int k = 0; k < children; ++k)
            codes[k] = build(bounds[k], bounds[k + 1], depth + 1);
        ExactBvh::Node& node = nodes[index];  // after the children: no reallocation anyway
        for (int k = 0; k < ExactBvh::kWidth; ++k) {
            const FloatBox& b = k < children ? box[k] : kEmpty;
            for (int a = 0; a < 3; ++a) {
                node.lo[a][k] = b.lo[a];
                node.hi[a][k] = b.hi[a];
            }
            node.child[k] = k < children ? codes[k] : ExactBvh::kNoChild;
        }
        return index;
    }
};

Status ExactBvh::build(const Impl& a, Prefetch prefetch) {
    nodes_.clear();
    bottom_.clear();
    first_.clear();
    meshes_.clear();
    root_ = kNoChild;
    prefetch_nodes_ = prefetch_rows_ = false;
    Status st;
    try {
        st = build_tree(a, prefetch);
    } catch (const std::bad_alloc&) {
        // As an Embree build that ran out of memory did: no tree, and the linear scan answers.
        st = Status::error(Code::too_large, "out of memory building exact's BVH");
    }
    if (!st.ok()) {  // whatever build_tree had made: none of it is walked
        std::vector<Node>().swap(nodes_);
        std::vector<QNode>().swap(bottom_);
        std::vector<std::uint32_t>().swap(first_);
        std::vector<const TriangleMesh*>().swap(meshes_);
        root_ = kNoChild;
    }
    return st;
}

Status ExactBvh::build_tree(const Impl& a, Prefetch prefetch) {
    const Scene& scene = *a.scene;
    std::size_t total = 0;
    for (const Object& o : scene.objects)
        total += o.primitive_count();
    if (total >= kNoChild - kLeafBit)  // a leaf's code holds its primitive's index in 31 bits
        return Status::error(Code::too_large, "the scene has too many primitives for exact's BVH");
    // The build's scratch (items, float nodes, codes) in mappings of their own
    // (engine/mapped_allocator.h): freed, they leave nothing in the heap.
    MappedVector<Item> items;
    items.reserve(total);
    first_.reserve(scene.objects.size() + 1);
    meshes_.reserve(scene.objects.size());
    for (const Object& o : scene.objects) {
        first_.push_back(static_cast<std::uint32_t>(items.size()));
        meshes_.push_back(o.kind == ObjectKind::sphere ? nullptr : o.mesh.get());
        const auto prims = static_cast<std::uint32_t>(o.primitive_count());
        for (std::uint32_t p = 0; p < prims; ++p) {
            Item it;
            it.box = primitive_box(a, o, p);
            for (int k = 0; k < 3; ++k) {
                if (!(it.box.lo[k] <= it.box.hi[k]))  // a NaN (the scene's checks let none through)
                    return Status::error(Code::internal, "a primitive's box is not a box");
                it.centre[k] = 0.5f * it.box.lo[k] + 0.5f * it.box.hi[k];
            }
            it.index = static_cast<std::uint32_t>(items.size());
            items.push_back(it);
        }
    }
    first_.push_back(static_cast<std::uint32_t>(items.size()));
    if (items.empty())
        return Status{};
    // Every inner node has two children or more, so there are fewer than there are items: room
    // for that many, so that the build never reallocates (a vector growing by doubling had held
    // up to twice the tree, and copied it each time); only the pages it uses are touched. The
    // float nodes are then quantized into the tree (128 B a node against 224), and freed.
    MappedVector<Node> built;
    built.reserve(items.size());
    ExactBvhBuilder builder{built};
    root_ = builder.build(items.data(), items.data() + items.size(), 0);
    MappedVector<Item>().swap(items);
    // The nodes whose children are all leaves, most of the tree, quantized into bottom_; the
    // others kept as they are (a walk passes more of them, and they are few).
    MappedVector<std::uint32_t> code(built.size());
    std::size_t inner = 0, bottom = 0;
    for (std::size_t i = 0; i < built.size(); ++i) {
        bool leaves = true;
        for (std::uint32_t c : built[i].child)
            leaves = leaves && (c & kLeafBit);
        code[i] = leaves ? kBottomBit | static_cast<std::uint32_t>(bottom++)
                         : static_cast<std::uint32_t>(inner++);
    }
    if (bottom >= kBottomBit || inner >= kBottomBit)  // either index would read as the other
        return Status::error(Code::too_large, "the scene has too many primitives for exact's BVH");
    const auto renamed = [&](std::uint32_t c) { return c & kLeafBit ? c : code[c]; };
    nodes_.reserve(inner);
    bottom_.resize(bottom);
    for (std::size_t i = 0; i < built.size(); ++i) {
        Node& n = built[i];
        for (std::uint32_t& c : n.child)
            c = renamed(c);
        if (code[i] & kBottomBit) {
            if (!quantize(n, bottom_[code[i] & ~kBottomBit]))
                return Status::error(Code::internal, "a box of exact's BVH is not finite");
        } else {
            nodes_.push_back(n);
        }
    }
    root_ = renamed(root_);
    const bool large =
        nodes_.size() * sizeof(Node) + bottom_.size() * sizeof(QNode) >= kPrefetchFromBytes;
    prefetch_nodes_ = prefetch == Prefetch::always || (prefetch == Prefetch::when_large && large);
    prefetch_rows_ = prefetch == Prefetch::always ||
                     (prefetch == Prefetch::when_large && large && first_.size() == 2);
    return Status{};
}

}  // namespace raycastd::engine::embree
