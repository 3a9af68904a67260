#pragma once
// Triangle and the watertight ray/triangle test used by every query.
//
// Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1), 2013: the vertices
// are translated to the ray origin, sheared so that the ray becomes the +z axis, and the 2-D
// edge functions U, V, W decide inside/outside. Edges shared by two triangles produce exactly
// negated edge functions, so a ray through a shared edge or vertex can never slip between them.
// An edge function within its rounding bound takes the sign of the exact triple product
// ((p − o) × (q − o))·d instead (engine/math/exact_sign.h; the paper recomputes a zero one
// precision up, which long double did here until 2026-12-06 and which can round to the wrong
// side: the differential fuzzer, seed 1242742). Both triangles of an edge take the same path,
// so the test stays watertight, and it is now exact: a line is given to the triangle on its
// side of the edge. Edges and vertices belong to the triangle (closed test).
// Once a hit is decided, t is recomputed as the plane crossing t = n·(a − o) / n·d in
// double-double (TwoSum/TwoProduct, Dekker 1971, Ogita, Rump & Oishi 2005): Woop's sheared t
// loses digits in the shear (a few ulps) and for grazing rays (~u/cos θ); this one is rounded
// once. The t error bound follows pbrt-v4 §6.8.4 (it bounds both).
//
// The tutorial's explained method (plane ⟨n,x⟩ = ⟨n,a⟩ with n = ac × ab, and the same-direction
// cross-product test) lives in engine/explain, the only place that needs it.

#include <optional>

#include "engine/math/ray.h"

namespace raycastd::engine {

struct Triangle {
    Vec3d a, b, c;
};

/// (b−a)×(c−a), with the edges brought to unit scale where the plain product would overflow or
/// underflow: what triangle_normal normalizes and is_degenerate compares with zero (for a caller
/// that needs both of one triangle).
Vec3d edge_cross(const Triangle& tri);

/// The plane crossing's normal (intersect_triangle's plane_t, and the four-lane kernels of
/// triangle_lanes.h, which must form the same bits): the edges b − a and c − a brought to unit
/// scale by the power of two `ke` (unit_scale), their cross product `n`, and γ₅ of its terms'
/// magnitudes `dn`, the bound of n's rounding by component.
struct PlaneNormal {
    double ke = 1.0;
    Vec3d n, dn;
};
PlaneNormal plane_normal(const Triangle& tri);

/// Unit geometric normal normalize((b−a)×(c−a)) (counter-clockwise front faces); zero vector
/// for a degenerate triangle.
Vec3d triangle_normal(const Triangle& tri);

/// True when (b−a)×(c−a) is exactly zero: such a triangle is never hit.
bool is_degenerate(const Triangle& tri);

/// Where a ray's line crosses a triangle that it hits outside [tmin, tmax] (intersect_triangle,
/// decide_triangle): the barycentrics as a Hit's u (weight of b) and v (weight of c). `crossed`
/// is set only then.
struct LineCrossing {
    double u = 0.0, v = 0.0;
    bool crossed = false;
};

/// The hit with t in [ray.tmin, ray.tmax] as a Hit (object/primitive left for the caller):
/// t, t_err, barycentrics u (weight of b) and v (weight of c); nullopt on a miss, for a ray in
/// the triangle's plane, and for a degenerate triangle. Never produces NaN for finite input.
/// front_face is always set; `want_normal = false` skips the normal. Where the line crosses
/// the triangle (the same inside test) but outside [tmin, tmax], `outside`, if given, receives
/// the crossing (refined's hit filter tells a ray's own triangle behind its origin from a
/// candidate missed at an edge).
std::optional<Hit> intersect_triangle(const Triangle& tri, const Ray& ray, bool want_normal = true,
                                      LineCrossing* outside = nullptr);

/// intersect_triangle's decision, for a caller that needs only that (an occlusion test): the
/// same rays hit and miss, and `outside` is the same, but where Woop's sheared t and its t_err
/// alone put the crossing inside [tmin, tmax] the hit carries them (t within t_err, as
/// intersect_triangle_fast's) instead of the double-double plane crossing; no normal.
std::optional<Hit> decide_triangle(const Triangle& tri, const Ray& ray,
                                   LineCrossing* outside = nullptr);

/// The magnitudes of the terms of each component of e1 × e2: (|e1.y·e2.z| + |e1.z·e2.y|, …).
/// With e1, e2 the edges b − a, c − a each rounded once, γ₅ of them bounds the rounding of the
/// normal (b − a)×(c − a) formed in double, component by component (each product and the
/// difference rounded once: γ₄ of the exact magnitudes; Higham 2002, Lemma 3.1).
inline Vec3d cross_magnitudes(const Vec3d& e1, const Vec3d& e2) {
    const Vec3d a1 = abs(e1), a2 = abs(e2);
    return {a1.y * a2.z + a1.z * a2.y, a1.z * a2.x + a1.x * a2.z, a1.x * a2.y + a1.y * a2.x};
}

/// intersect_triangle's inside test (Woop's, watertight) with t taken from the test's own
/// sheared coordinates instead of the double-double plane crossing: within the reported t_err
/// (pbrt-v4 §6.8.4), not within an ulp. A hit is reported only where t − t_err ≥ tmin (so a ray
/// spawned off the triangle does not find it again). For `fast`.
std::optional<Hit> intersect_triangle_fast(const Triangle& tri, const Ray& ray,
                                           bool want_normal = true);

/// Where the ray's line meets the triangle's plane, in double precision, whether or not that
/// point is inside: t and the barycentrics u, v (possibly negative), with the same arithmetic as
/// intersect_triangle. Used to refine a hit another (single-precision) test already decided.
/// nullopt when the line is parallel to the plane or the triangle is degenerate.
std::optional<Hit> triangle_plane_hit(const Triangle& tri, const Ray& ray, bool want_normal = true);

}  // namespace raycastd::engine
