#include "engine/accel/point_bvh.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

#include <tbb/parallel_invoke.h>
#if defined(__SSE__)
#include <xmmintrin.h>
#endif

#include "engine/accel/point_query.h"
#include "engine/math/float_bounds.h"

namespace raycastd::engine {

namespace {

/// Beyond this many float ulps (2⁻²⁰) a plane's normal is not taken as unit, nor an edge's normal
/// as orthogonal to the plane's: the bound's factor 1/(1 + |c|)/|n|² then stays above 1 − 2⁻¹⁸.
constexpr double kUnitTolerance = 1.0 / (1 << 20);
/// The relative slack of the squared radii: the factor above, and the relative roundings of
/// A₊² + B₊² in float (γ₃ of u_f): 2⁻¹⁸ + 3·2⁻²⁴ < 2⁻¹⁶.
constexpr double kRadiusSlack = 1.0 + 1.0 / (1 << 16);
/// Query points farther than this from the centre are answered by brute force: the double
/// squares of the far walk would overflow (near 1e154).
constexpr double kMaxQuery = 1e100;
/// Query points farther than this many S from the centre are walked in double: float's ε grows
/// with |q| and would stop culling (docs/accuracy.md's far suite: 0.29 ms a point in float
/// against Embree's 0.045).
constexpr double kFarQuery = 64.0;
/// Trees smaller than this S are walked in double too: the float bound's proof takes its
/// roundings as relative, which fails once squared distances fall below FLT_MIN (~1e-38, so
/// distances below ~1e-19, reached by ε when S is below ~1e-13; found in review).
constexpr double kTinyScale = 0x1p-40;
constexpr float kInfF = std::numeric_limits<float>::infinity();
/// Subtrees of at least this many triangles are built in parallel.
constexpr std::uint32_t kParallelTriangles = 16384;

/// Where a range of n > 8 triangles splits: the median, moved to a multiple of 4 so that packs
/// stay full (a range of 4k triangles splits into two such ranges).
std::uint32_t split_size(std::uint32_t n) {
    return std::clamp((n / 2 + 2) / 4 * 4, 4u, n - 4);
}

/// The nodes and packs of the subtree over n triangles: they follow from n alone.
struct Shape {
    std::uint32_t nodes, packs;
};
Shape shape(std::uint32_t n) {
    if (n <= 8)
        return {1, (n + 3) / 4};
    const Shape l = shape(split_size(n)), r = shape(n - split_size(n));
    return {1 + l.nodes + r.nodes, l.packs + r.packs};
}

/// Lane l of a Node4 set to binary node n's box, pointing at `child` (count > 0: a leaf's first
/// pack).
template <class Node4, class Node>
void set_child(Node4& n4, int l, const Node& n, std::uint32_t child, std::uint32_t count) {
    for (int k = 0; k < 3; ++k) {
        for (int j = 0; j < 3; ++j)
            n4.axes[k][j][l] = n.axes[k][j];
        n4.centre[k][l] = n.centre[k];
        n4.half[k][l] = n.half[k];
    }
    n4.child[l] = child;
    n4.count[l] = count;
}

/// Nodes of at most this many triangles get oriented boxes (fitted to their vertices: each
/// triangle is read once a level, log₂(64/4) + 1 times in all).
constexpr std::uint32_t kOrientedTriangles = 64;

double abs_sum(const Vec3d& v) {
    return std::abs(v.x) + std::abs(v.y) + std::abs(v.z);
}

/// The smallest float ≥ v, +inf beyond float's range (float_up would convert out of range).
float up_or_inf(double v) {
    return v > std::numeric_limits<float>::max() ? kInfF : float_up(v);
}
/// The squared float radius that covers every distance ≤ r (+inf for r = +inf). Rounded to
/// nearest after a factor 1 + 2⁻²² rather than by float_up (a call to nextafterf each time the
/// reach shrinks): the nearest float to v(1 + 2⁻²²) is at least v(1 + 2⁻²²) − 2⁻²⁴v > v for a
/// normal v; below float's normal range float_up decides.
float radius2(double r) {
    if (!(r < kInfinity))
        return kInfF;
    const double v = r * r * kRadiusSlack;
    if (v < std::numeric_limits<float>::min())
        return float_up(v);
    return v * (1.0 + 1.0 / (1 << 22)) > std::numeric_limits<float>::max()
               ? kInfF
               : static_cast<float>(v * (1.0 + 1.0 / (1 << 22)));
}

/// The double vector of a float-rounded unit vector, or nullopt when rounding (or the input)
/// leaves it further than kUnitTolerance from unit length.
std::optional<Vec3d> rounded_unit(const Vec3d& v) {
    const double len = length(v);
    if (!(len > 0.0) || !std::isfinite(len))
        return std::nullopt;
    const Vec3d u = v / len;
    const Vec3d f{static_cast<float>(u.x), static_cast<float>(u.y), static_cast<float>(u.z)};
    if (!(std::abs(length(f) - 1.0) <= kUnitTolerance))
        return std::nullopt;
    return f;
}

/// The smallest float o with m·v ≤ o for the three vertices, in exact arithmetic: each double dot
/// product is off by at most γ₄·(Σ|m_i||v_i|) (Higham 2002 §3.1: three products and two sums,
/// one more u for v's own rounding relative to the centre), which is added before rounding up.
float offset_above(const Vec3d& m, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
    double o = -kInfinity;
    for (const Vec3d* v : {&a, &b, &c})
        o = std::max(o, dot(m, *v) + gamma(4) * abs_sum(m) * max_abs(*v));
    return float_up(o);
}

}  // namespace

TrianglePlanes triangle_planes(const Vec3d& a, const Vec3d& b, const Vec3d& c, double slab) {
    const TrianglePlanes none;
    const auto n = rounded_unit(cross(b - a, c - a));
    if (!n)
        return none;
    TrianglePlanes t;
    // The plane through a, and the largest distance of a vertex from it (the float normal leans
    // by up to u_f, the offset rounds), as for offset_above.
    const double o = static_cast<float>(dot(*n, a));
    double r = 0;
    for (const Vec3d* v : {&a, &b, &c})
        r = std::max(
            r, std::abs(dot(*n, *v) - o) + gamma(4) * (abs_sum(*n) * max_abs(*v) + std::abs(o)));
    if (!(r <= slab))
        return none;
    t.plane[0] = static_cast<float>(n->x);
    t.plane[1] = static_cast<float>(n->y);
    t.plane[2] = static_cast<float>(n->z);
    t.plane[3] = static_cast<float>(o);
    const Vec3d* v[3] = {&a, &b, &c};
    for (int e = 0; e < 3; ++e) {
        // (v1 − v0) × n points out of the triangle across the edge v0→v1 (counter-clockwise
        // about n), away from the third vertex.
        const auto m = rounded_unit(cross(*v[(e + 1) % 3] - *v[e], *n));
        if (!m || !(std::abs(dot(*m, *n)) <= kUnitTolerance))
            return none;
        t.edges[e][0] = static_cast<float>(m->x);
        t.edges[e][1] = static_cast<float>(m->y);
        t.edges[e][2] = static_cast<float>(m->z);
        t.edges[e][3] = offset_above(*m, a, b, c);
    }
    // The corner rule needs the double planes close to the true ones (every angle's sine above
    // 1e-6: the normal's double rounding is then below u/1e-6 ≪ u_f) and the corner acute
    // (cos ≥ 1e-3, decided with room in double).
    const double area2 = length(cross(b - a, c - a));
    for (int i = 0; i < 3; ++i) {
        const Vec3d u1 = *v[(i + 1) % 3] - *v[i], u2 = *v[(i + 2) % 3] - *v[i];
        const double l = length(u1) * length(u2);
        const bool usable = area2 >= 1e-6 * l && dot(u1, u2) >= 1e-3 * l;
        for (int k = 0; k < 3; ++k)
            t.corner[i][k] =
                usable ? static_cast<float>((*v[i])[k]) : std::numeric_limits<float>::quiet_NaN();
    }
    return t;
}

void set_lane(PlanePack& pack, int lane, const TrianglePlanes& t) {
    for (int k = 0; k < 4; ++k) {
        pack.plane[k][lane] = t.plane[k];
        for (int e = 0; e < 3; ++e)
            pack.edges[e][k][lane] = t.edges[e][k];
    }
    for (int i = 0; i < 3; ++i) {
        for (int k = 0; k < 3; ++k)
            pack.corner[i][k][lane] = t.corner[i][k];
    }
}

namespace {

// Four lanes in one SIMD register, through GCC's and Clang's vector extensions (SSE on x86-64,
// NEON elsewhere): a lane loop with std::max stays scalar (its NaN rule is a branch).
using F4 = float __attribute__((vector_size(16)));
using I4 = std::int32_t __attribute__((vector_size(16)));

F4 load4(const float* p) {
    F4 v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
/// Lane by lane a > b ? a : b; b where either is NaN.
F4 max4(F4 a, F4 b) {
#if defined(__SSE__)
    // maxps is exactly this rule (Intel SDM, MAXPS: the second operand where either is NaN).
    return reinterpret_cast<F4>(
        _mm_max_ps(reinterpret_cast<__m128>(a), reinterpret_cast<__m128>(b)));
#else
    const I4 m = a > b;
    return reinterpret_cast<F4>((reinterpret_cast<I4>(a) & m) | (reinterpret_cast<I4>(b) & ~m));
#endif
}
F4 abs4(F4 a) {
    return reinterpret_cast<F4>(reinterpret_cast<I4>(a) &
                                I4{0x7fffffff, 0x7fffffff, 0x7fffffff, 0x7fffffff});
}
F4 sqrt4(F4 a) {
#if defined(__SSE__)
    return reinterpret_cast<F4>(_mm_sqrt_ps(reinterpret_cast<__m128>(a)));
#else
    return F4{std::sqrt(a[0]), std::sqrt(a[1]), std::sqrt(a[2]), std::sqrt(a[3])};
#endif
}
/// Bit l set where lane l of `in` is all ones (movmskps where SSE has it).
unsigned lane_mask(I4 in) {
#if defined(__SSE__)
    return static_cast<unsigned>(_mm_movemask_ps(reinterpret_cast<__m128>(in)));
#else
    return unsigned(in[0] & 1) | unsigned(in[1] & 2) | unsigned(in[2] & 4) | unsigned(in[3] & 8);
#endif
}
/// The lanes of four squared distances that are not beyond r2 (a NaN is not: visited, never
/// culled) and whose id is not kInvalidId, as bits.
unsigned within(const float d2[4], float r2, const std::uint32_t id[4]) {
    I4 ids;
    std::memcpy(&ids, id, sizeof ids);
    const F4 r = {r2, r2, r2, r2};
    return lane_mask(~(load4(d2) > r) & (ids != I4{-1, -1, -1, -1}));
}
unsigned within(const double d2[4], double r2, const std::uint32_t id[4]) {
    unsigned mask = 0;
    for (int l = 0; l < 4; ++l)
        mask |= unsigned(id[l] != kInvalidId && !(d2[l] > r2)) << l;
    return mask;
}
/// The four lanes' plane function r[0]·q.x + r[1]·q.y + r[2]·q.z − r[3].
F4 plane4(const float (&r)[4][4], F4 qx, F4 qy, F4 qz) {
    return load4(r[0]) * qx + load4(r[1]) * qy + load4(r[2]) * qz - load4(r[3]);
}

}  // namespace

namespace {

/// lower_bounds2 in float, inlined into the leaf visit (a call per pack was measurable).
[[gnu::always_inline]] inline void float_bounds2(const PlanePack& pack, const float q[3], float eps,
                                                 float out[4]) {
    const F4 qx = {q[0], q[0], q[0], q[0]}, qy = {q[1], q[1], q[1], q[1]},
             qz = {q[2], q[2], q[2], q[2]}, e = {eps, eps, eps, eps}, zero = {};
    // A₊ and B_e less ε; max_e B_e₊ (a NaN anywhere gives 0: tested, never culled).
    const F4 a = max4(abs4(plane4(pack.plane, qx, qy, qz)) - e, zero);
    const F4 be[3] = {plane4(pack.edges[0], qx, qy, qz) - e, plane4(pack.edges[1], qx, qy, qz) - e,
                      plane4(pack.edges[2], qx, qy, qz) - e};
    const F4 b = max4(max4(max4(be[0], be[1]), be[2]), zero);
    // The corner rule: |q − v|² of the corner (at most one: their regions are disjoint) whose
    // two edges both have B > 0; 0 where none has, or where its corner is NaN (not usable).
    F4 v2 = zero;
    for (int i = 0; i < 3; ++i) {
        const F4 dx = qx - load4(pack.corner[i][0]), dy = qy - load4(pack.corner[i][1]),
                 dz = qz - load4(pack.corner[i][2]);
        const F4 d2 = dx * dx + dy * dy + dz * dz;
        const I4 in = (be[(i + 2) % 3] > zero) & (be[i] > zero) & (d2 >= zero);
        v2 = reinterpret_cast<F4>((reinterpret_cast<I4>(d2) & in) |
                                  (reinterpret_cast<I4>(v2) & ~in));
    }
    // (|q − v| − ε)₊², by the vector square root (SSE sqrtps).
    const F4 v = max4(sqrt4(v2) - e, zero);
    const F4 r = max4(v * v, a * a + b * b);
    std::memcpy(out, &r, sizeof r);
}

}  // namespace

void lower_bounds2(const PlanePack& pack, const float q[3], float eps, float out[4]) {
    float_bounds2(pack, q, eps, out);
}

void lower_bounds2(const PlanePack& pack, const double q[3], const BoundMargins& m, double out[4]) {
    // The float version's steps lane by lane in double (the stored floats are exact in double),
    // with the Gram bound kept whole: far away A ≈ |q| and the factor 1/(1 + |c|) of the float
    // version (and |n| ≠ 1) would cost |c|·|q| ~ u_f |q| of the distance, more than the
    // triangles' differences. Here the norms are exact to u and, for a ≥ A, b ≥ B ≥ 0,
    //   a² − 2c·ab + b² ≥ A² + B² − 2c·AB − c²(A² + B²)
    // (its least value on the boundary of that quadrant), over 1 − c² ≤ 1.
    for (int l = 0; l < 4; ++l) {
        auto plane = [&](const float(&r)[4][4]) {
            return double(r[0][l]) * q[0] + double(r[1][l]) * q[1] + double(r[2][l]) * q[2] -
                   double(r[3][l]);
        };
        auto normal = [&](const float(&r)[4][4]) { return Vec3d{r[0][l], r[1][l], r[2][l]}; };
        const Vec3d n = normal(pack.plane);
        const double nn = length(n);
        // Zero planes (a sliver's): nn = 0 and a = NaN, which the caller tests.
        const double a = std::max(std::abs(plane(pack.plane)) - m.plane, 0.0) / nn;
        double best = a * a, be[3];
        for (int e = 0; e < 3; ++e) {
            be[e] = plane(pack.edges[e]);
            const Vec3d me = normal(pack.edges[e]);
            const double mm = length(me);
            const double b = std::max(be[e] - m.plane, 0.0) / mm;
            const double c = std::abs(dot(n, me)) / (nn * mm);
            best = std::max(best, a * a + b * b - 2.0 * c * a * b - c * c * (a * a + b * b));
        }
        double v2 = 0.0;
        for (int i = 0; i < 3; ++i) {
            const double dx = q[0] - pack.corner[i][0][l], dy = q[1] - pack.corner[i][1][l],
                         dz = q[2] - pack.corner[i][2][l];
            const double d2 = dx * dx + dy * dy + dz * dz;
            if (be[(i + 2) % 3] > m.region && be[i] > m.region && d2 >= 0.0)
                v2 = d2;
        }
        const double v = std::max(std::sqrt(v2) - m.corner, 0.0);
        out[l] = std::max(v * v, best);
    }
}

BoundMargins float_margins(double qmax, double scale) {
    // ε of the file comment: the float evaluation of a plane (γ₄ of u_f times Σ|n_i q_i| + |o|,
    // |n|₁ ≤ √3), the rounding of p − centre to q (√3 u_f |q|∞), the subtractions of the slab
    // and of ε themselves (u_f of their operands), and the slab (8 u_f S): 40 u_f covers the sum
    // (≈ 13 u_f |q|∞ + 14 u_f S) with room. It also covers what the corner rule needs (below).
    const double eps = 40.0 * kFloatUnitRoundoff * (qmax + scale);
    return {eps, eps, eps};
}

BoundMargins double_margins(double qmax, double scale) {
    BoundMargins m;
    // The slab (8 u_f S), and the double evaluation with p − centre's rounding (γ₄ of u of
    // |n|₁|q|∞ + |o| ≤ 1.8 |q|∞ + S, and u √3 |q|∞): 32 u (|q|∞ + S) with room.
    m.plane = 8.0 * kFloatUnitRoundoff * scale + 32.0 * kDoubleUnitRoundoff * (qmax + scale);
    // That p is beyond the true edge lines: the float edge normal is within u_f of the true one
    // (1.5 u_f |q|∞ through p) and its offset within 2 u_f S of the true edge's.
    m.region = m.plane + 4.0 * kFloatUnitRoundoff * (qmax + scale);
    // The float corner is within u_f S of the vertex; the double |q − v| is accurate to a few u.
    m.corner = kFloatUnitRoundoff * scale + 8.0 * kDoubleUnitRoundoff * (qmax + scale);
    return m;
}

bool PointBvh::suits(const Scene& scene) {
    if (scene.triangle_count() == 0 || scene.sphere_count() > kMaxSpheres)
        return false;
    const Bounds3 b = scene.bounds();
    // Relative to the centre the float walk (points within 64 S) then squares distances below
    // float's range (3.4e38). The centre itself must be finite: (lo + hi)/2 overflows for
    // coordinates near DBL_MAX even when the diagonal is small, and a tree of NaN boxes would
    // send every query to brute force. Below 1e-30 the float copies of the planes and boxes
    // would come near float's subnormals, where their roundings are no longer relative.
    const double size = max_abs(b.diagonal());
    return size <= 1e16 && size >= 1e-30 && is_finite(b.center());
}

PointBvh::PointBvh(const Scene& scene)
    : scene_(scene), bounds_(scene.bounds()), center_(bounds_.center()) {
    std::vector<Item> items;
    double largest = 0;
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        const Object& o = scene.objects[i];
        if (o.kind == ObjectKind::sphere) {
            spheres_.push_back(i);
            continue;
        }
        for (std::uint32_t k = 0; k < o.mesh->size(); ++k) {
            if (is_degenerate(o.mesh->triangle(k)))
                continue;  // never offered (closest_point_on_triangle gives no point)
            const Triangle t = relative(i, k);
            Item it{(t.a + t.b + t.c) / 3.0, {}, cross(t.b - t.a, t.c - t.a), i, k};
            for (const Vec3d& v : {t.a, t.b, t.c}) {
                it.box.extend(v);
                largest = std::max(largest, max_abs(v));
            }
            items.push_back(it);
        }
    }
    scale_ = 2.0 * largest;
    if (items.empty())
        return;
    const auto n = static_cast<std::uint32_t>(items.size());
    const Shape whole = shape(n);
    nodes_.resize(whole.nodes);
    packs_.resize(whole.packs);
    build(0, n, items, 0, 0);
    // The walked tree: four children a node. A root that is a leaf becomes one lane.
    if (nodes_[0].count > 0) {
        nodes4_.emplace_back();
        set_child(nodes4_[0], 0, nodes_[0], nodes_[0].index, nodes_[0].count);
        for (int l = 1; l < 4; ++l)
            nodes4_[0].child[l] = kInvalidId;
    } else {
        nodes4_.reserve(whole.nodes / 3 + 1);
        collapse(0);
    }
    nodes4_.shrink_to_fit();  // the reservation is an upper bound
    std::vector<Node>().swap(nodes_);
}

std::uint32_t PointBvh::collapse(std::uint32_t b) {
    // The node's children, each inner one replaced by its own two while there is room.
    std::uint32_t lanes[4] = {b + 1, nodes_[b].index, kInvalidId, kInvalidId};
    int n = 2;
    // Each of the two children is opened once, so that the lanes are the node's grandchildren
    // [LL, RL, LR, RR] (two binary levels a step). Opening the first lane again and again gave
    // [LLL, R, LR, LLR]: boxes of three depths side by side, and R's half of the tree descending
    // one binary level a Node4 (found in review).
    for (int i = 0; i < 2 && n < 4; ++i) {
        if (nodes_[lanes[i]].count == 0) {
            const std::uint32_t inner = lanes[i];
            lanes[i] = inner + 1;
            lanes[n++] = nodes_[inner].index;
        }
    }
    const auto index = static_cast<std::uint32_t>(nodes4_.size());
    nodes4_.emplace_back();
    for (int l = 0; l < 4; ++l) {
        if (l >= n) {
            nodes4_[index].child[l] = kInvalidId;
            continue;
        }
        const Node& c = nodes_[lanes[l]];
        // The recursion may grow nodes4_: the lane is written through the index afterwards.
        const std::uint32_t child = c.count > 0 ? c.index : collapse(lanes[l]);
        set_child(nodes4_[index], l, c, child, c.count);
    }
    return index;
}

Triangle PointBvh::relative(std::uint32_t object, std::uint32_t prim) const {
    const Triangle t = scene_.objects[object].mesh->triangle(prim);
    return {t.a - center_, t.b - center_, t.c - center_};
}

void PointBvh::fit(Node& node, const std::vector<Vec3d>& points, bool oriented,
                   const Vec3d& normal_sum, double area_sum) {
    // The frame: the triangles' mean normal where they are nearly flat (|Σ a_i n_i| ≥ ½ Σ a_i:
    // a patch of a surface, whose box is then thin across it), else the world axes. The rows are
    // rounded to float and kept only if still orthonormal within kUnitTolerance, so that
    // |axes·w| ≤ (1 + 2⁻¹⁹)|w| (Gershgorin on axes·axesᵀ): the box distance in that frame then
    // bounds the true one from below up to kRadiusSlack.
    Vec3d r[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const double len = length(normal_sum);
    if (oriented && len > 0 && len >= 0.5 * area_sum) {
        const Vec3d z = normal_sum / len;
        const Vec3d x = normalize(cross(std::abs(z.x) < 0.6 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0}, z));
        const Vec3d f[3] = {x, cross(z, x), z};
        Vec3d rounded[3];
        bool ok = true;
        for (int k = 0; k < 3; ++k)
            rounded[k] = Vec3d(Vec3f(f[k]));
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j)
                ok = ok && std::abs(dot(rounded[i], rounded[j]) - (i == j)) <= kUnitTolerance;
        }
        if (ok)
            std::copy(rounded, rounded + 3, r);
    }
    // The centre: the middle of the points' extents in that frame, back in scene coordinates
    // (any centre will do: the half-extents are measured from the float one).
    Vec3d c;
    for (int k = 0; k < 3; ++k) {
        double lo = kInfinity, hi = -kInfinity;
        for (const Vec3d& v : points) {
            lo = std::min(lo, dot(r[k], v));
            hi = std::max(hi, dot(r[k], v));
        }
        c += r[k] * (0.5 * (lo + hi));
    }
    for (int k = 0; k < 3; ++k)
        node.centre[k] = static_cast<float>(c[static_cast<std::size_t>(k)]);
    const Vec3d cf{node.centre[0], node.centre[1], node.centre[2]};
    for (int k = 0; k < 3; ++k) {
        // The double dot product's rounding (γ₄ with that of v − cf), and the points' own: each
        // was computed as vertex − scene centre, within u·|v| a component (γ₂ for room).
        double h = 0;
        for (const Vec3d& v : points) {
            const Vec3d d = v - cf;
            h = std::max(h, std::abs(dot(r[k], d)) +
                                abs_sum(r[k]) * (gamma(4) * max_abs(d) + gamma(2) * max_abs(v)));
        }
        node.half[k] = up_or_inf(h);
        for (std::size_t j = 0; j < 3; ++j)
            node.axes[k][j] = static_cast<float>(r[k][j]);
    }
}

void PointBvh::build(std::uint32_t begin, std::uint32_t end, std::vector<Item>& items,
                     std::uint32_t index, std::uint32_t pack) {
    Bounds3 centroids;
    Vec3d normal_sum;
    double area_sum = 0;
    for (std::uint32_t i = begin; i < end; ++i) {
        centroids.extend(items[i].centroid);
        normal_sum += items[i].normal;
        area_sum += length(items[i].normal);
    }
    const std::uint32_t n = end - begin;
    if (n <= 8)
        fill_leaf(index, pack, begin, end, items);
    std::vector<Vec3d> points;
    if (n <= kOrientedTriangles) {
        // Small nodes, patches of a surface: an oriented box around their vertices, thin across
        // the patch (an axis-aligned box of a tilted patch is as thick as the patch is wide, and
        // from outside a convex surface that let a whole cap of leaves within reach).
        for (std::uint32_t i = begin; i < end; ++i) {
            const Triangle t = relative(items[i].object, items[i].prim);
            points.insert(points.end(), {t.a, t.b, t.c});
        }
    } else {
        // Larger ones: the world axes, around the triangles' boxes (refitting oriented boxes from
        // the children's corners inflated them level by level: measured slower).
        Bounds3 box;
        for (std::uint32_t i = begin; i < end; ++i)
            box.extend(items[i].box);
        for (int m = 0; m < 8; ++m)
            points.push_back({m & 1 ? box.hi.x : box.lo.x, m & 2 ? box.hi.y : box.lo.y,
                              m & 4 ? box.hi.z : box.lo.z});
    }
    fit(nodes_[index], points, n <= kOrientedTriangles, normal_sum, area_sum);
    if (n <= 8)
        return;
    // The median on the centroids' longest axis, then the two halves (in parallel while large:
    // each writes its own ranges of nodes_ and packs_, known from the sizes alone).
    const std::size_t axis = max_abs_dimension(centroids.diagonal());
    const std::uint32_t half = split_size(n);
    const std::uint32_t mid = begin + half;
    std::nth_element(
        items.begin() + begin, items.begin() + mid, items.begin() + end,
        [axis](const Item& x, const Item& y) { return x.centroid[axis] < y.centroid[axis]; });
    const Shape left = shape(half);
    const std::uint32_t right = index + 1 + left.nodes;
    nodes_[index].index = right;
    auto build_left = [&] { build(begin, mid, items, index + 1, pack); };
    auto build_right = [&] { build(mid, end, items, right, pack + left.packs); };
    if (n >= kParallelTriangles) {
        tbb::parallel_invoke(build_left, build_right);
    } else {
        build_left();
        build_right();
    }
}

void PointBvh::fill_leaf(std::uint32_t node, std::uint32_t pack, std::uint32_t begin,
                         std::uint32_t end, const std::vector<Item>& items) {
    nodes_[node].index = pack;
    nodes_[node].count = end - begin;
    // A vertex lies within 8 u_f·S of the float plane through a (the normal's and the offset's
    // float rounding, with room): the slab folded into the query's margin.
    const double slab = 8.0 * kFloatUnitRoundoff * scale_;
    for (std::uint32_t i = begin; i < end; i += 4) {
        Pack p;
        for (int l = 0; l < 4; ++l) {
            p.object[l] = p.prim[l] = kInvalidId;
            if (i + l >= end)
                continue;
            const Item& it = items[i + l];
            const Triangle t = relative(it.object, it.prim);
            set_lane(p.planes, l, triangle_planes(t.a, t.b, t.c, slab));
            p.object[l] = it.object;
            p.prim[l] = it.prim;
        }
        packs_[pack++] = p;
    }
}

/// The squared radii of one query: `t2` for the triangles' bounds (the candidates' reach), `b2`
/// for the boxes (the reach plus the margin of the planes' and boxes' evaluation).
template <class T>
struct PointBvh::Reach {
    double max_distance;
    BoundMargins m;
    T t2 = std::numeric_limits<T>::infinity(), b2 = std::numeric_limits<T>::infinity();
    /// m.plane rounded up to float, for the float leaf bounds (once a query, not a pack).
    float eps = up_or_inf(m.plane);

    void update(const PointCandidates& c) {
        const double r = std::min(max_distance, c.cull_distance());
        t2 = squared(r);
        b2 = squared(r + m.plane);
    }
    /// r² with kRadiusSlack, rounded up in float (+inf for r = +inf).
    static T squared(double r) {
        if constexpr (std::is_same_v<T, float>) {
            return radius2(r);
        } else {
            // The far walk's roundings are all relative and in double (a few u): 2⁻⁴⁰ covers
            // them; kRadiusSlack's 2⁻¹⁶ would be more than the triangles' differences far away.
            return r < kInfinity ? r * r * (1.0 + std::ldexp(1.0, -40)) : kInfinity;
        }
    }
};

namespace {

/// The squared distances from q to the four lanes' oriented boxes (0 inside), in float, in one
/// SIMD step (a world-axis lane's rows are 1 and 0: exact). Against the true point:
/// |axes·(q − centre)| is off by at most ~8 u_f (|q|∞ + S) a component (the subtraction, the dot
/// product's γ₃, p's rounding), inside ε (√3 of it: 14 u_f), and the rest rounds relatively,
/// inside kRadiusSlack. A NaN gives 0 (max4): visited, never culled.
template <class Node4>
[[gnu::always_inline]] inline void box_distances2(const Node4& n, const float q[3], float out[4]) {
    const F4 d[3] = {F4{q[0], q[0], q[0], q[0]} - load4(n.centre[0]),
                     F4{q[1], q[1], q[1], q[1]} - load4(n.centre[1]),
                     F4{q[2], q[2], q[2], q[2]} - load4(n.centre[2])};
    F4 d2 = {};
    for (int k = 0; k < 3; ++k) {
        const F4 y =
            load4(n.axes[k][0]) * d[0] + load4(n.axes[k][1]) * d[1] + load4(n.axes[k][2]) * d[2];
        const F4 g = max4(abs4(y) - load4(n.half[k]), F4{});
        d2 += g * g;
    }
    std::memcpy(out, &d2, sizeof d2);
}

/// The far walk's node bound, lane by lane: the squared distance from q (double) to the ball
/// around the lane's box, |q − centre| − |h|₂ (1 + 2⁻¹⁸): the box's rows are orthonormal only
/// within 2⁻²⁰, which in the box's frame would cost 2⁻²⁰ |q| (far away, more than the nodes'
/// differences), while the ball around it is measured directly (its radius covers
/// A⁻¹ = Aᵀ(AAᵀ)⁻¹).
template <class Node4>
void box_distances2(const Node4& n, const double q[3], double out[4]) {
    for (int l = 0; l < 4; ++l) {
        const double dx = q[0] - n.centre[0][l], dy = q[1] - n.centre[1][l],
                     dz = q[2] - n.centre[2][l];
        const double h0 = n.half[0][l], h1 = n.half[1][l], h2 = n.half[2][l];
        const double r = std::sqrt(h0 * h0 + h1 * h1 + h2 * h2) * (1.0 + std::ldexp(1.0, -18));
        // std::max keeps a NaN (its first argument): never culled.
        const double g = std::max(std::sqrt(dx * dx + dy * dy + dz * dz) - r, 0.0);
        out[l] = g * g;
    }
}

/// Four bounds with a NaN replaced by 0.
void nan_to_zero(float b[4]) {
    const F4 v = max4(load4(b), F4{});  // max4's NaN rule
    std::memcpy(b, &v, sizeof v);
}
void nan_to_zero(double b[4]) {
    for (int l = 0; l < 4; ++l)
        b[l] = std::isnan(b[l]) ? 0.0 : b[l];
}

/// The leaf bounds at float or double.
void bounds(const PlanePack& pack, const float q[3], const BoundMargins&, float eps, float out[4]) {
    float_bounds2(pack, q, eps, out);
}
void bounds(const PlanePack& pack, const double q[3], const BoundMargins& m, float, double out[4]) {
    lower_bounds2(pack, q, m, out);
}

}  // namespace

template <class T>
void PointBvh::visit_leaf(std::uint32_t first_pack, std::uint32_t count, const Vec3d& p,
                          const T q[3], Reach<T>& reach, PointCandidates& c) const {
    // The bounds of the leaf's triangles (at most 8), then the exact tests in increasing order of
    // the bound: the first one found shrinks the reach for the others, which the bounds then cull.
    assert(count <= 8);
    T lb2[8];
    unsigned mask = 0;  // bit 4k + l: lane l of the k-th pack is within reach
    const std::uint32_t packs = (count + 3) / 4;
    for (std::uint32_t k = 0; k < packs; ++k) {
        const Pack& pack = packs_[first_pack + k];
        bounds(pack.planes, q, reach.m, reach.eps, lb2 + 4 * k);
        // A NaN bound is tested first, never culled (within, and 0 here).
        nan_to_zero(lb2 + 4 * k);
        mask |= within(lb2 + 4 * k, reach.t2, pack.object) << (4 * k);
    }
    // Smallest bound first, equal bounds in lane order (a stable sort's order), by selection:
    // usually the first test or two shrink the reach past the others, so sorting all of them
    // would be mostly wasted.
    while (mask != 0) {
        int i = __builtin_ctz(mask);
        for (unsigned r = mask & (mask - 1); r != 0; r &= r - 1) {
            const int k = __builtin_ctz(r);
            if (lb2[k] < lb2[i])
                i = k;
        }
        if (lb2[i] > reach.t2)
            break;
        mask &= ~(1u << i);
        const Pack& pack = packs_[first_pack + i / 4];
        const std::uint32_t object = pack.object[i % 4], prim = pack.prim[i % 4];
        // The tree holds no degenerate triangle (the constructor), and p is finite.
        const Triangle t = scene_.objects[object].mesh->triangle(prim);
        offer_closest_point(closest_point_on_valid_triangle(t, p), object, prim, reach.max_distance,
                            c);
        reach.update(c);
    }
}

std::optional<PointHit> PointBvh::closest_point(const Vec3d& p, double max_distance) const {
    if (!is_finite(p))
        return std::nullopt;
    PointCandidates c(candidate_err_bound(p, bounds_));
    for (std::uint32_t s : spheres_)
        offer_primitive(scene_, s, 0, p, max_distance, c);
    const Vec3d pc = p - center_;
    if (!(max_abs(pc) <= kMaxQuery))
        return linear_closest_point(scene_, p, max_distance);
    if (nodes4_.empty())
        return finish_closest_point(scene_, c);
    const double qmax = max_abs(pc);
    if (qmax > kFarQuery * scale_ || scale_ < kTinyScale) {
        const double q[3] = {pc.x, pc.y, pc.z};
        Reach<double> reach{max_distance, double_margins(qmax, scale_)};
        walk(p, q, reach, c);
    } else {
        const float q[3] = {static_cast<float>(pc.x), static_cast<float>(pc.y),
                            static_cast<float>(pc.z)};
        const double fmax = std::max(std::abs(double(q[0])),
                                     std::max(std::abs(double(q[1])), std::abs(double(q[2]))));
        Reach<float> reach{max_distance, float_margins(fmax, scale_)};
        walk(p, q, reach, c);
    }
    return finish_closest_point(scene_, c);
}

template <class T>
void PointBvh::walk(const Vec3d& p, const T q[3], Reach<T>& reach, PointCandidates& c) const {
    reach.update(c);
    // A child waiting: a Node4 (count 0) or a leaf, with its squared box distance.
    struct Entry {
        std::uint32_t child, count;
        T d2;
    };
    Entry stack[3 * 32 + 4];  // three entries a level at most; depth ≤ 32 (log₄ of 2³² · 2)
    int top = 0;
    Entry at{0, 0, T(0)};  // the root
    for (;;) {
        if (at.count > 0) {
            visit_leaf(at.child, at.count, p, q, reach, c);
        } else {
            const Node4& n = nodes4_[at.child];
            T d2[4];
            box_distances2(n, q, d2);
            // The lanes within reach, as bits.
            unsigned mask = within(d2, reach.b2, n.child);
            if (mask != 0) {
                // Near the surface most nodes have one child within reach: taken at once. Two or
                // more are ordered nearest first, equal distances in lane order (the order the
                // exact tests then come in is the same as a stable sort's), the nearest taken
                // now, the others pushed farthest first; leaves are visited as they come.
                int l = __builtin_ctz(mask);
                mask &= mask - 1;
                if (mask == 0) {
                    at = {n.child[l], n.count[l], d2[l]};
                    continue;
                }
                Entry near[4];
                near[0] = {n.child[l], n.count[l], d2[l]};
                int m = 1;
                for (; mask != 0; mask &= mask - 1) {
                    l = __builtin_ctz(mask);
                    const Entry e{n.child[l], n.count[l], d2[l]};
                    int j = m++;
                    for (; j > 0 && near[j - 1].d2 > e.d2; --j)
                        near[j] = near[j - 1];
                    near[j] = e;
                }
                for (int j = m - 1; j > 0; --j) {
                    assert(top < int(sizeof stack / sizeof stack[0]));
                    stack[top++] = near[j];
                }
                at = near[0];
                continue;
            }
        }
        // The next waiting child still within reach (the reach may have shrunk since it was
        // pushed).
        for (;;) {
            if (top == 0)
                return;
            at = stack[--top];
            if (!(at.d2 > reach.b2))
                break;
        }
    }
}

std::size_t PointBvh::memory_bytes() const {
    return nodes4_.capacity() * sizeof(Node4) + packs_.capacity() * sizeof(Pack) +
           spheres_.capacity() * sizeof(std::uint32_t) + sizeof(*this);
}

}  // namespace raycastd::engine
