#include "tests/stress/reference.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

#include <quadmath.h>

#include "engine/math/float_bounds.h"
#include "tests/stress/quad_vec.h"

namespace raycastd::stress {

using engine::Object;
using engine::ObjectKind;
using engine::Ray;
using engine::Scene;
using engine::Vec3d;

namespace {

/// Origins farther than this many primitive sizes are first moved along the ray's line to the
/// primitive (near_line_shift): from ~2^56 the products of differences from the origin are no
/// longer exact in quad, and the margins, relative to the origin's distance, put every decision
/// inside the bands. The engine moves such rays too (from ~1e8 scene sizes,
/// engine/accel/embree/float_ray.h) and is judged at the scale of the moved origin. Nearer
/// origins are judged as before.
constexpr double kFarOrigin = 0x1p50;

/// The parameter s of the line's point nearest `p`, for an origin farther than kFarOrigin
/// sizes from p; 0 otherwise. o + s·d is formed in quad: off the line by ~2^-113 of |o|.
Quad near_line_shift(const QVec& o, const QVec& d, const QVec& p, double size) {
    if (!(to_double(norm(p - o)) > kFarOrigin * size))
        return 0;
    return dot(p - o, d) / dot(d, d);
}

/// The sphere: Δ/4 = a·r² − |f × d|² (Lagrange's identity) with f = o − c exact in quad.
void sphere_crossings(const engine::Sphere& s, std::uint32_t object, const Ray& ray,
                      const Bands& bands, std::vector<RefCrossing>& out) {
    const QVec d = q(ray.direction);
    const Quad shift = near_line_shift(q(ray.origin), d, q(s.center), s.radius);
    const QVec f = q(ray.origin) + d * shift - q(s.center);
    const Quad r = s.radius;
    const Quad a = dot(d, d);
    const Quad beta = dot(f, d);
    const QVec fxd = cross(f, d);
    const Quad cr2 = dot(fxd, fxd);
    const Quad disc = a * r * r - cr2;
    const Quad dist = sqrtq(cr2 / a);
    const Quad len_f = norm(f);
    RefCrossing c;
    c.object = object;
    c.primitive = 0;
    c.margin = to_double((r - dist) / (len_f + r));
    c.t_scale = to_double((len_f + r) / sqrtq(a));
    if (c.margin < -bands.decision)
        return;
    if (disc <= 0) {
        // Tangent, or a near miss within the band: the candidate point is the closest approach.
        c.t = c.t_hi = shift - beta / a;
        c.front_face = true;
        out.push_back(c);
        return;
    }
    const Quad sq = sqrtq(disc);
    const Quad qq = -(beta + (beta < 0 ? -sq : sq));
    const Quad gamma_c = dot(f, f) - r * r;
    Quad t0 = qq / a, t1 = gamma_c / qq;
    if (t0 > t1)
        std::swap(t0, t1);
    t0 += shift;
    t1 += shift;
    c.t = c.t_hi = t0;
    c.front_face = true;  // below the closest approach the ray moves towards the centre
    out.push_back(c);
    c.t = c.t_hi = t1;
    c.front_face = false;
    out.push_back(c);
}

/// Relative margin of the three edges, computed in T (double for the filter, quad for the
/// truth): E_bc = d·(B × (C − B)) etc. (B × C written as B × (C − B) keeps the rounding of the
/// product at the scale of the edge, not of the distance), normalised by |d|·R·L with R the
/// largest vertex distance from the origin and L the longest edge. A double kernel (Woop's
/// shear) rounds each sheared coordinate at ~u·R and each edge function at ~u·R·L, so this is
/// the unit in which its decisions are uncertain.
template <class V, class S, class Norm>
S triangle_margin(const V& A, const V& B, const V& C, const V& d, S len_d, Norm&& nrm) {
    const V e[3] = {C - B, A - C, B - A};
    const V p[3] = {B, C, A};
    const S r = std::max(nrm(A), std::max(nrm(B), nrm(C)));
    const S l = std::max(nrm(e[0]), std::max(nrm(e[1]), nrm(e[2])));
    const S scale = len_d * r * l;
    if (!(scale > 0))
        return -std::numeric_limits<double>::infinity();
    S mp = std::numeric_limits<double>::infinity(), mm = mp;
    for (int i = 0; i < 3; ++i) {
        const S E = dot(d, cross(p[i], e[i]));
        mp = std::min(mp, E / scale);
        mm = std::min(mm, -E / scale);
    }
    return std::max(mp, mm);
}

void triangle_crossings(const engine::Triangle& tri, std::uint32_t object, std::uint32_t prim,
                        const Ray& ray, const Bands& bands, std::vector<RefCrossing>& out) {
    // Double-precision filter: its margin is within a few u of the truth (see above), far
    // inside the 1e-9 slack, so no candidate within the band is dropped. Not for an origin
    // more than 2^26 triangle sizes away: its differences A, B, C round by more than 2^-26 of
    // an edge, and past ~2^53 the edges C − B formed from them vanish (a margin of −inf had
    // dropped every crossing of rays from 1e17 away).
    const double edge = std::max({engine::max_abs(tri.b - tri.a), engine::max_abs(tri.c - tri.a),
                                  engine::max_abs(tri.c - tri.b)});
    if (engine::max_abs(tri.a - ray.origin) <= 0x1p26 * edge) {
        const Vec3d A = tri.a - ray.origin, B = tri.b - ray.origin, C = tri.c - ray.origin;
        const double m = triangle_margin(A, B, C, ray.direction, engine::length(ray.direction),
                                         [](const Vec3d& v) { return engine::length(v); });
        if (!(m >= -bands.decision - 1e-9))
            return;
    }
    const QVec d = q(ray.direction);
    const QVec a = q(tri.a), b = q(tri.b), c = q(tri.c);
    const Quad shift = near_line_shift(q(ray.origin), d, a, edge);
    const QVec o = q(ray.origin) + d * shift;
    const QVec n = cross(b - a, c - a);
    if (n.x == 0 && n.y == 0 && n.z == 0)
        return;  // degenerate: never hit
    const Quad nd = dot(n, d);
    const QVec A = a - o, B = b - o, C = c - o;
    const Quad len_d = norm(d);
    RefCrossing x;
    x.object = object;
    x.primitive = prim;
    x.margin = to_double(triangle_margin(A, B, C, d, len_d, [](const QVec& v) { return norm(v); }));
    if (x.margin < -bands.decision)
        return;
    x.t_scale = to_double(std::max(norm(A), std::max(norm(B), norm(C))) / len_d);
    if (nd == 0) {
        // The line lies in (or parallel to) the plane: no crossing, but where it runs alongside
        // the triangle (the projections of the vertices on the line) matters to its neighbours.
        const Quad dd = dot(d, d);
        const Quad ta = shift + dot(A, d) / dd, tb = shift + dot(B, d) / dd,
                   tc = shift + dot(C, d) / dd;
        x.parallel = true;
        x.t = std::min(ta, std::min(tb, tc));
        x.t_hi = std::max(ta, std::max(tb, tc));
        out.push_back(x);
        return;
    }
    x.t = shift + dot(n, A) / nd;
    x.t_hi = x.t;
    x.front_face = nd < 0;
    out.push_back(x);
}

/// Slab test of the line (any t) against a box widened by a relative slack: a cheap, sound cull.
bool line_near_box(const engine::Bounds3& box, const Ray& ray) {
    const Vec3d diag = box.hi - box.lo;
    const double slack =
        1e-6 * (engine::length(diag) + engine::length(box.center() - ray.origin)) + 1e-300;
    double t0 = -std::numeric_limits<double>::infinity(), t1 = -t0;
    for (std::size_t k = 0; k < 3; ++k) {
        const double lo = box.lo[k] - slack, hi = box.hi[k] + slack;
        const double o = ray.origin[k], dk = ray.direction[k];
        if (dk == 0.0) {
            if (o < lo || o > hi)
                return false;
            continue;
        }
        double ta = (lo - o) / dk, tb = (hi - o) / dk;
        if (ta > tb)
            std::swap(ta, tb);
        t0 = std::max(t0, ta - 1e-9 * std::abs(ta));
        t1 = std::min(t1, tb + 1e-9 * std::abs(tb));
    }
    return t0 <= t1;
}

double tie_band(const Bands& b, Quad t, double t_scale) {
    return std::max(b.tie_ulps * ulp(to_double(t)), b.tie_rel * t_scale);
}

}  // namespace

double ulp(double x) {
    const double ax = std::abs(x);
    return std::nextafter(ax, std::numeric_limits<double>::infinity()) - ax;
}

Bands exact_bands() {
    Bands b;
    b.decision = 64 * engine::kDoubleUnitRoundoff;
    b.range = 64 * engine::kDoubleUnitRoundoff;
    b.tie_ulps = 10;
    b.tie_rel = 0;
    return b;
}

Bands float_bands() {
    Bands b;
    b.decision = 64 * engine::kFloatUnitRoundoff;
    b.range = 64 * engine::kFloatUnitRoundoff;
    b.tie_ulps = 10;
    b.tie_rel = 64 * engine::kFloatUnitRoundoff;
    return b;
}

std::vector<RefCrossing> reference_crossings(const Scene& scene, const Ray& ray,
                                             const Bands& bands) {
    std::vector<RefCrossing> all;
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        const Object& o = scene.objects[i];
        if (o.kind == ObjectKind::sphere) {
            sphere_crossings(o.sphere, i, ray, bands, all);
            continue;
        }
        if (!line_near_box(o.mesh->bounds(), ray))
            continue;
        for (std::size_t p = 0; p < o.mesh->size(); ++p) {
            triangle_crossings(o.mesh->triangle(p), i, static_cast<std::uint32_t>(p), ray, bands,
                               all);
        }
    }
    std::vector<RefCrossing> kept;
    for (const RefCrossing& c : all) {
        const double band_t = bands.range * c.t_scale;
        if (c.t_hi >= Quad(ray.tmin) - band_t && c.t <= Quad(ray.tmax) + band_t)
            kept.push_back(c);
    }
    return kept;
}

RefAnswer reference_closest(const Scene& scene, const Ray& ray, const Bands& bands,
                            const std::vector<bool>& closed) {
    return classify(reference_crossings(scene, ray, bands), ray, bands, closed);
}

RefAnswer classify(const std::vector<RefCrossing>& crossings, const Ray& ray, const Bands& bands,
                   const std::vector<bool>& closed) {
    RefAnswer ans;
    for (const RefCrossing& c : crossings) {
        const double band_t = bands.range * c.t_scale;
        if (c.margin >= -bands.decision && c.t_hi >= Quad(ray.tmin) - band_t &&
            c.t <= Quad(ray.tmax) + band_t) {
            ans.crossings.push_back(c);
        }
    }
    const auto& cs = ans.crossings;
    auto is_closed = [&](std::uint32_t obj) { return obj < closed.size() && closed[obj]; };
    auto in_range_exact = [&](const RefCrossing& c) {
        return c.t >= Quad(ray.tmin) && c.t <= Quad(ray.tmax);
    };
    auto in_range_robust = [&](const RefCrossing& c) {
        const double band_t = bands.range * c.t_scale;
        return c.t > Quad(ray.tmin) + band_t && c.t < Quad(ray.tmax) - band_t;
    };

    // The exact answer: margins ≥ 0 in range, ordered by (t, object, primitive) as the API does.
    const RefCrossing* best = nullptr;
    for (const RefCrossing& c : cs) {
        if (c.parallel || c.margin < 0 || !in_range_exact(c))
            continue;
        if (!best || c.t < best->t ||
            (c.t == best->t && std::make_pair(c.object, c.primitive) <
                                   std::make_pair(best->object, best->primitive))) {
            best = &c;
        }
    }
    if (best) {
        ans.hit = true;
        ans.object = best->object;
        ans.primitive = best->primitive;
        ans.t = best->t;
    }

    // Robust crossings: inside by more than the band, or, on a closed mesh, a point where every
    // crossing of that mesh within the tie band faces the same way (the line passes through the
    // surface at a shared edge or vertex, whichever triangle takes it).
    auto robust = [&](const RefCrossing& c) {
        if (c.parallel || !in_range_robust(c))
            return false;
        if (c.margin > bands.decision)
            return true;
        if (c.margin < 0 || !is_closed(c.object))
            return false;
        // The neighbourhood of the crossing: 1e-9 of the distance scale, far wider than any
        // double kernel's uncertainty, so that an exit right after the entry (a corner clipped
        // at a vertex, a silhouette) makes it a near-tie.
        const double tb = std::max(tie_band(bands, c.t, c.t_scale), 1e-9 * c.t_scale);
        for (const RefCrossing& o : cs) {
            if (o.object != c.object || o.t > c.t + tb || o.t_hi < c.t - tb)
                continue;
            if (o.parallel || o.front_face != c.front_face)
                return false;  // grazes, not enters
        }
        return true;
    };
    const RefCrossing* first_robust = nullptr;
    for (const RefCrossing& c : cs) {
        if (robust(c) && (!first_robust || c.t < first_robust->t))
            first_robust = &c;
    }
    if (!first_robust) {
        ans.hit_robust = cs.empty();  // nothing within the bands at all: a robust miss
        return ans;
    }
    ans.hit_robust = true;
    ans.t_first_robust = first_robust->t;
    ans.first_on_closed = is_closed(first_robust->object);
    // The first object is decided when every crossing that could come first is of one object.
    const double tb = tie_band(bands, first_robust->t, first_robust->t_scale);
    ans.object_robust = true;
    for (const RefCrossing& c : cs) {
        if (c.t <= first_robust->t + tb && c.object != first_robust->object &&
            !(c.parallel && c.t_hi < first_robust->t - tb)) {
            ans.object_robust = false;
        }
    }
    return ans;
}

bool is_closed_mesh(const engine::TriangleMesh& mesh) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
    for (const auto& t : mesh.triangles) {
        for (int k = 0; k < 3; ++k)
            ++directed[{t[k], t[(k + 1) % 3]}];
    }
    for (const auto& [edge, n] : directed) {
        if (n != 1)
            return false;
        auto it = directed.find({edge.second, edge.first});
        if (it == directed.end() || it->second != 1)
            return false;
    }
    return !mesh.triangles.empty();
}

}  // namespace raycastd::stress
