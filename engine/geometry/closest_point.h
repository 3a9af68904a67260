#pragma once
// The closest point of a triangle or a sphere to a query point, in double precision, and the
// PointHit the point queries return.
//
// Triangle: the region-based method of Ericson, *Real-Time Collision Detection* (2005) §5.1.5
// ("ClosestPtPointTriangle"): the signs of six dot products d1..d6 and of the three scaled
// barycentric determinants va, vb, vc place p in the Voronoi region of a vertex, an edge or the
// face, and only that region's point is computed. Two changes to the book's code, both for the
// API's tie rule (lower object, then lower primitive wins an exact tie):
//   * an edge's point is computed from its two endpoints taken in a fixed (lexicographic) order,
//     and a vertex's point is the vertex itself, so two triangles that share the edge or the
//     vertex compute the same point and the same distance, bit for bit;
//   * the face region's distance is the plane distance |n·(p − a)| / |n| (n = ab × ac), and an
//     edge's |w − e·t| (w = p − s₀, e = s₁ − s₀), whose rounding follows |p − a| and |e| rather
//     than the coordinates' magnitude (|p − q| would carry q's rounding).
// Sphere: q = c + r·(p − c)/|p − c|, distance ||p − c| − r| (exact up to the rounding of |p − c|).
//
// Error: each distance comes with `err`, a bound on its rounding error that is also the width of
// "on the surface": 16 ulps of the magnitude of the coordinates involved (max |p_i|, |a_i|, |b_i|,
// |c_i|; for spheres |c_i| + r), i.e. γ₁₆·scale (Higham 2002 §3.1). The computation itself stays
// within about 4u·scale (closest_point_test.cpp measures it against a long-double evaluation of
// the same regions: docs/accuracy.md); the rest of the margin covers a client's point that was
// computed to lie on the surface and rounded on the way (p = (a + b + c)/3 is off the plane by
// about u·scale). A point within err of a surface is on it: distance 0 (engine/points).
// Degenerate (zero-area) triangles are not part of the surface, as for intersect: they give no
// point (closest_point_on_triangle returns nullopt).

#include <cstdint>
#include <optional>
#include <type_traits>
#include <vector>

#include "engine/geometry/sphere.h"
#include "engine/geometry/triangle.h"
#include "engine/math/bounds.h"

namespace raycastd::engine {

/// A primitive's closest point to a query point.
struct ClosestPoint {
    Vec3d point;
    double distance = kInfinity;
    double err = 0.0;  ///< bound on the rounding of `distance` (see the file comment)
    double u = 0.0;  ///< barycentric weight of b (point = (1−u−v)·a + u·b + v·c); 0 for spheres
    double v = 0.0;  ///< barycentric weight of c
};

/// The closest point of the triangle to p and its distance; nullopt for a degenerate triangle
/// ((b−a)×(c−a) exactly zero) and for non-finite p.
std::optional<ClosestPoint> closest_point_on_triangle(const Triangle& tri, const Vec3d& p);
/// The same for a triangle known not to be degenerate and a finite p, without checking them
/// again (the point tree holds no degenerate triangle and checks p once a query: the checks were
/// 4 % of a closest-point query's instructions on bench_points' shell).
ClosestPoint closest_point_on_valid_triangle(const Triangle& tri, const Vec3d& p);

/// The closest point of the sphere's surface to p; for p at the centre (every surface point is
/// as close) the point at +x, c + (r, 0, 0).
ClosestPoint closest_point_on_sphere(const Sphere& s, const Vec3d& p);

/// The answer of a closest-point query: the nearest surface point, the object and primitive it
/// lies on, its barycentrics (triangles) and the primitive's unit geometric normal there (for a
/// sphere the outward normal at the point; for a triangle normalize((b−a)×(c−a))).
struct PointHit {
    Vec3d point;
    double distance = kInfinity;
    double err = 0.0;  ///< ClosestPoint::err of the winner
    std::uint32_t object = kInvalidId;
    std::uint32_t primitive = kInvalidId;
    double u = 0.0, v = 0.0;
    Vec3d normal;

    bool valid() const { return object != kInvalidId; }
};

/// The API's order for closest points: the smaller distance, where two distances differ by more
/// than their error bounds together; otherwise (a tie within rounding) the lower object, then the
/// lower primitive. Not a strict weak order on near-ties of three or more: callers collect the
/// candidates within the error of the smallest distance and pick by id (PointCandidates).
inline bool clearly_closer(const PointHit& a, const PointHit& b) {
    return a.distance + a.err + b.err < b.distance;
}

/// A bound on the `err` of every primitive's closest point to p in a scene whose bounds are
/// `scene` (γ₁₆ of max|p_i| + max|scene_i|, which is at least each triangle's and sphere's scale
/// of the file comment, with room for the order of the sums); what PointCandidates takes.
double candidate_err_bound(const Vec3d& p, const Bounds3& scene);

/// Keeps the winner of a closest-point search: among the candidates whose distance ties the
/// smallest one within their error bounds, the lowest (object, primitive). Candidates that can
/// still tie are kept in a fixed buffer of kKeep (no allocation per query), and beyond it (a
/// point equidistant from many primitives, e.g. the apex of a fan, where vertex points tie bit
/// for bit) in a vector.
/// The winner does not depend on the order of the candidates (the order a tree visits them in):
/// a candidate is refused, or dropped, only when no candidate still to come can tie with it,
/// which takes a bound E on every candidate's err, given to the constructor (for a search over a
/// scene, candidate_err_bound), and nothing is dropped for want of room. With only the errors
/// seen so far, a candidate H refused beside the best A so far would not be taken back when a
/// closer B with a much larger bound (a primitive with far larger coordinates) came that ties
/// with H: H < A < B by ids, offered A, H, B, gave A where the id order gives H (found in review;
/// PointCandidates.TheWinnerDoesNotDependOnTheOrder); and dropping the highest ids from a full
/// buffer lost a true tie to candidates that E kept but did not tie in the end (review of the
/// fix; PointCandidates.AFullBufferLosesNoTie).
class PointCandidates {
  public:
    /// `err_bound`: E above, at least the err of every candidate to be offered; 0 (only the errors
    /// seen so far: the order can matter when they differ widely) for a caller without one.
    explicit PointCandidates(double err_bound) : err_bound_(err_bound) {}
    /// Offers one candidate.
    void offer(const PointHit& h);
    /// The winner; an invalid PointHit when nothing was offered.
    PointHit winner() const;
    /// Beyond this distance no primitive can win or tie (for culling): the smallest distance so
    /// far plus four times the larger of its error bound and E (a tying primitive's bound is at
    /// most E); +inf while empty.
    double cull_distance() const;

  private:
    /// Drops the candidates that can no longer tie with b.
    void prune(const PointHit& b);
    int size() const { return count_ + static_cast<int>(overflow_.size()); }
    const PointHit& at(int i) const {
        return i < kKeep ? kept_[i].hit : overflow_[static_cast<std::size_t>(i - kKeep)];
    }
    PointHit& at(int i) {
        return i < kKeep ? kept_[i].hit : overflow_[static_cast<std::size_t>(i - kKeep)];
    }
    /// Whether h could still tie with the best at the end: not more than h's bound and the
    /// larger of b's and E beyond b, the best so far (the final best is no farther than b and
    /// its bound at most E).
    bool may_tie(const PointHit& h, const PointHit& b) const;

    static constexpr int kKeep = 16;
    /// A kept candidate, begun when offered: a PointHit's defaults written into all of them
    /// would cost a 1.4 KB copy per query (measured: 3 % of a closest-point query's
    /// instructions on bench_points' shell). Only kept_[0, count_) hold one.
    union Slot {
        Slot() {}
        PointHit hit;
    };
    static_assert(std::is_trivially_destructible_v<PointHit>);  // nothing for ~Slot to end
    Slot kept_[kKeep];
    std::vector<PointHit> overflow_;  ///< candidates beyond kKeep (empty: no allocation)
    double err_bound_ = 0;
    int count_ = 0;  ///< slots of kept_ in use
    int best_ = -1;  ///< index (kept_, then overflow_) of the smallest distance
};

}  // namespace raycastd::engine
