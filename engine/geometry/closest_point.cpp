#include "engine/geometry/closest_point.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "engine/math/float_bounds.h"

namespace raycastd::engine {

namespace {

/// The error bound of every distance here, and the width of "on the surface" (see the header):
/// γ₁₆ times the magnitude of the coordinates involved.
constexpr double kErrScale = gamma(16);

/// a < b in lexicographic order of (x, y, z): the fixed order of an edge's endpoints.
bool lex_less(const Vec3d& a, const Vec3d& b) {
    if (a.x != b.x)
        return a.x < b.x;
    if (a.y != b.y)
        return a.y < b.y;
    return a.z < b.z;
}

/// The closest point q of the segment [p0, p1] to p and its distance, computed from the
/// endpoints in lexicographic order so that the two triangles sharing the edge get the same point
/// and distance, bit for bit. Returns the parameter of the point measured from p0 as given (0 at
/// p0, 1 at p1).
double closest_on_segment(const Vec3d& p0, const Vec3d& p1, const Vec3d& p, Vec3d& q,
                          double& distance) {
    const bool swap = lex_less(p1, p0);
    const Vec3d& s0 = swap ? p1 : p0;
    const Vec3d& s1 = swap ? p0 : p1;
    const Vec3d e = s1 - s0, w = p - s0;
    const double t = std::clamp(dot(w, e) / dot(e, e), 0.0, 1.0);
    // The endpoints themselves, not s0 + e·t rounded: a vertex's point is the vertex.
    q = t == 0.0 ? s0 : (t == 1.0 ? s1 : s0 + e * t);
    // Inside the edge the distance is |w − e·t|, whose rounding follows |p − s0| and |e|; |p − q|
    // would carry q's rounding, which follows the coordinates' magnitude (against the quad
    // reference of docs/accuracy.md: 5 ulps of a distance a tenth of the coordinates that way, 3
    // this way).
    distance = t == 0.0 ? length(w) : (t == 1.0 ? length(p - s1) : length(w - e * t));
    return swap ? 1.0 - t : t;
}

/// The point of one edge region: the edge a→b of the triangle as (u, v) = (1−s)·ua + s·ub
/// (the barycentrics of a and b).
ClosestPoint edge_point(const Vec3d& a, const Vec3d& b, const Vec3d& p, double ua_u, double ua_v,
                        double ub_u, double ub_v) {
    ClosestPoint out;
    const double s = closest_on_segment(a, b, p, out.point, out.distance);
    out.u = (1.0 - s) * ua_u + s * ub_u;
    out.v = (1.0 - s) * ua_v + s * ub_v;
    return out;
}

/// The closest of the three edges: for a sliver whose face-region determinant rounds to zero or
/// below (the face region then has no interior worth computing).
ClosestPoint closest_of_edges(const Triangle& t, const Vec3d& p) {
    ClosestPoint best = edge_point(t.a, t.b, p, 0, 0, 1, 0);
    ClosestPoint ac = edge_point(t.a, t.c, p, 0, 0, 0, 1);
    if (ac.distance < best.distance)
        best = ac;
    ClosestPoint bc = edge_point(t.b, t.c, p, 1, 0, 0, 1);
    if (bc.distance < best.distance)
        best = bc;
    return best;
}

ClosestPoint vertex_point(const Vec3d& x, const Vec3d& p, double u, double v) {
    ClosestPoint out;
    out.point = x;
    out.distance = length(p - x);
    out.u = u;
    out.v = v;
    return out;
}

/// Ericson's regions, in the book's order (RTCD §5.1.5); the edge and vertex points through the
/// helpers above.
ClosestPoint regions(const Triangle& t, const Vec3d& p) {
    const Vec3d ab = t.b - t.a, ac = t.c - t.a, ap = p - t.a;
    const double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0)
        return vertex_point(t.a, p, 0, 0);
    const Vec3d bp = p - t.b;
    const double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3)
        return vertex_point(t.b, p, 1, 0);
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0)
        return edge_point(t.a, t.b, p, 0, 0, 1, 0);
    const Vec3d cp = p - t.c;
    const double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6)
        return vertex_point(t.c, p, 0, 1);
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0)
        return edge_point(t.a, t.c, p, 0, 0, 0, 1);
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0)
        return edge_point(t.b, t.c, p, 1, 0, 0, 1);
    const double denom = va + vb + vc;
    if (!(denom > 0.0))
        return closest_of_edges(t, p);
    // The face: p projects inside. The point from the barycentrics, the distance from the plane.
    ClosestPoint out;
    out.u = vb / denom;
    out.v = vc / denom;
    out.point = t.a + ab * out.u + ac * out.v;
    const Vec3d n = cross(ab, ac);
    out.distance = std::abs(dot(n, ap)) / length(n);
    return out;
}

}  // namespace

std::optional<ClosestPoint> closest_point_on_triangle(const Triangle& tri, const Vec3d& p) {
    if (is_degenerate(tri) || !is_finite(p))
        return std::nullopt;
    return closest_point_on_valid_triangle(tri, p);
}

ClosestPoint closest_point_on_valid_triangle(const Triangle& tri, const Vec3d& p) {
    assert(!is_degenerate(tri) && is_finite(p));
    // Ericson's region tests multiply two dot products, four lengths: beyond 2^±240 they
    // overflow or underflow (a triangle and point 1e78 across had a null barycentric, 1e155 a
    // null distance). The triangle and p are then scaled to unit size by a power of two, which
    // is exact and leaves the barycentrics as they are; the point and distance scale back.
    // (A point far from a small triangle, lengths of both kinds at once, is not helped.)
    const double m = std::max({max_abs(tri.b - tri.a), max_abs(tri.c - tri.a), max_abs(p - tri.a)});
    ClosestPoint out;
    if (m > 0x1p240 || m < 0x1p-240) {
        const double k = power_to_unit(m);
        out = regions(Triangle{tri.a * k, tri.b * k, tri.c * k}, p * k);
        out.point = out.point / k;
        out.distance = out.distance / k;
    } else {
        out = regions(tri, p);
    }
    const double scale =
        std::max({max_abs(p), max_abs(tri.a), max_abs(tri.b), max_abs(tri.c), 1e-300});
    out.err = kErrScale * scale;
    return out;
}

ClosestPoint closest_point_on_sphere(const Sphere& s, const Vec3d& p) {
    ClosestPoint out;
    const Vec3d f = p - s.center;
    // |f| by its largest component where |f|² over- or underflows (a point 1e155 from the
    // centre had an infinite distance).
    const double f2 = dot(f, f);
    const double len = f2 > 0x1p-1000 && f2 < 0x1p1000 ? std::sqrt(f2) : scaled_length(f);
    if (len == 0.0) {
        out.point = s.center + Vec3d{s.radius, 0.0, 0.0};
        out.distance = s.radius;
    } else {
        out.point = s.center + f * (s.radius / len);
        out.distance = std::abs(len - s.radius);
    }
    out.err = kErrScale * std::max(max_abs(p) + max_abs(s.center) + s.radius, 1e-300);
    return out;
}

namespace {

/// Lower (object, primitive) first.
bool lower_ids(const PointHit& a, const PointHit& b) {
    if (a.object != b.object)
        return a.object < b.object;
    return a.primitive < b.primitive;
}

/// Whether h can still tie with or beat `best`: its distance is within both error bounds.
bool near(const PointHit& h, const PointHit& best) {
    return h.distance <= best.distance + best.err + h.err;
}

}  // namespace

double candidate_err_bound(const Vec3d& p, const Bounds3& scene) {
    const double m = scene.empty() ? 0.0 : std::max(max_abs(scene.lo), max_abs(scene.hi));
    // A triangle's scale is max(|p|, |a|, |b|, |c|) ≤ |p| + m; a sphere's |p| + |c| + r, whose
    // |c_i| + r is a coordinate of its bounds up to the rounding of the two sums (a few ulps).
    // Scaled before the sum, which would overflow for coordinates near DBL_MAX.
    const double slack = 1.0 + 8.0 * kDoubleUnitRoundoff;
    return std::max(kErrScale * max_abs(p) + kErrScale * m, kErrScale * 1e-300) * slack;
}

bool PointCandidates::may_tie(const PointHit& h, const PointHit& b) const {
    return h.distance <= b.distance + std::max(b.err, err_bound_) + h.err;
}

void PointCandidates::offer(const PointHit& h) {
    if (best_ >= 0 && !may_tie(h, at(best_)))
        return;
    const bool new_best = best_ < 0 || h.distance < at(best_).distance ||
                          (h.distance == at(best_).distance && lower_ids(h, at(best_)));
    // Every kKeep candidates, drop those that can no longer tie (a search rarely gets here).
    if (size() >= kKeep && size() % kKeep == 0)
        prune(new_best ? h : at(best_));
    if (count_ < kKeep) {
        // The slot's PointHit begins here (a placement new: PointHit's default member
        // initialisers make its default constructor non-trivial, so assigning to the union's
        // inactive member would not begin it).
        ::new (static_cast<void*>(&kept_[count_].hit)) PointHit(h);
        ++count_;
    } else {
        overflow_.push_back(h);
    }
    if (new_best)
        best_ = size() - 1;
}

void PointCandidates::prune(const PointHit& b) {
    // Keeps, in order, what may still tie with b (the best, or the candidate about to become it);
    // slots [0, n) were all written before, so plain assignment suffices.
    const int total = size();
    int n = 0;
    for (int i = 0; i < total; ++i) {
        if (!may_tie(at(i), b)) {
            if (i == best_)
                best_ = -1;  // h is the new best: set by offer
            continue;
        }
        if (i == best_)
            best_ = n;
        if (n != i)
            at(n) = at(i);
        ++n;
    }
    count_ = std::min(n, kKeep);
    overflow_.resize(static_cast<std::size_t>(std::max(n - kKeep, 0)));
}

PointHit PointCandidates::winner() const {
    if (best_ < 0)
        return PointHit{};
    const PointHit& b = at(best_);
    int win = best_;
    for (int i = 0; i < size(); ++i) {
        if (near(at(i), b) && lower_ids(at(i), at(win)))
            win = i;
    }
    return at(win);
}

double PointCandidates::cull_distance() const {
    if (best_ < 0)
        return kInfinity;
    return at(best_).distance + 4.0 * std::max(at(best_).err, err_bound_);
}

}  // namespace raycastd::engine
