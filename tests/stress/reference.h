#pragma once
// The quad-precision reference intersector: the truth the precision ladder is measured against
// (issue 6). Used only by tests and benches.
//
// Arithmetic is GCC's __float128 (IEEE binary128, 113-bit significand, u_q = 2^-113 ≈ 9.6e-35):
// every difference of two doubles whose exponents differ by less than 60 is exact in it, and
// every product of two doubles is exact (106 bits). The formulas are deliberately not the
// engine's:
//   * sphere: Δ/4 = a·r² − |f × d|² (Lagrange's identity, |f|²|d|² − (f·d)² = |f × d|²), with
//     f = o − c exact; roots t = (−β ∓ √(Δ/4))/a, the near one as γ/q (Numerical Recipes §5.6);
//   * triangle: the decision from the three Plücker-style triple products
//     E_bc = d·((b−o)×(c−o)), E_ca = d·((c−o)×(a−o)), E_ab = d·((a−o)×(b−o)) (the unsheared form
//     of Woop, Benthin & Wald's edge functions, JCGT 2013), inside when all share a sign; t from
//     the plane, t = n·(a − o) / n·d with n = (b − a)×(c − a).
// Its own error is ~1e-30 relative, ~15 orders below the double ulp it judges: a decision whose
// margin is below the bands of this header is called a near-tie and never judged.
//
// Decision margins are relative and dimensionless: for a triangle min_i(±E_i / (|d|·|P_i|·|Q_i|))
// (the sine-like distance of the line from the edge, per edge; ± the sign of the orientation),
// for a sphere (r − dist)/(|f| + r) with dist the distance of the line from the centre. Positive
// means hit, negative miss, and a double-precision kernel decides correctly whenever the margin
// exceeds a small multiple of u = 2^-53 (its inputs are rounded at that relative scale).

#include <cstdint>
#include <vector>

#include "engine/scene/scene.h"

namespace raycastd::stress {

using Quad = __float128;

/// One crossing of the ray's line with one primitive (a sphere gives up to two), whether or not
/// the crossing is inside the primitive: `margin` says how far in (> 0) or out (< 0) it is.
struct RefCrossing {
    std::uint32_t object = 0;
    std::uint32_t primitive = 0;
    Quad t = 0;              ///< parameter along the ray, in units of the given direction
    double margin = 0;       ///< signed relative decision margin (see header comment)
    double t_scale = 0;      ///< distance scale of the computation / |d|: the unit of range bands
    bool front_face = true;  ///< the ray arrives against the stored normal
    /// The line is parallel to (or lies in) the triangle's plane: never a hit (the API's
    /// in-plane rule), but a line touching a closed mesh along a face makes nearby crossings
    /// of that mesh near-ties. t .. t_hi is where the line runs alongside the triangle.
    bool parallel = false;
    Quad t_hi = 0;
};

/// Near-tie bands: below these the reference does not judge a decision.
struct Bands {
    double decision = 0;  ///< |margin| below this is a hit/miss near-tie
    double range = 0;     ///< |t − tmin| or |tmax − t| below range·t_scale is a near-tie
    double tie_ulps = 0;  ///< two crossings whose t differ by ≤ tie_ulps·ulp(t) tie ...
    double tie_rel = 0;   ///< ... or by ≤ tie_rel·t_scale (whichever is larger)
};

/// The bands the engine documents for `exact` (double decisions): 64·u.
Bands exact_bands();
/// The bands for `refined` and `fast` (Embree's float traversal decides): 64·u_float.
Bands float_bands();

/// Every crossing of the ray with the scene whose margin is ≥ −band.decision and whose t lies in
/// [tmin, tmax] widened by the range band, unsorted.
std::vector<RefCrossing> reference_crossings(const engine::Scene& scene, const engine::Ray& ray,
                                             const Bands& bands);

/// The reference's closest hit and how robust each of its decisions is.
struct RefAnswer {
    bool hit = false;  ///< in exact arithmetic (margins ≥ 0, tmin ≤ t ≤ tmax)
    std::uint32_t object = 0, primitive = 0;
    Quad t = 0;
    /// The hit/miss decision is outside the bands (or the first hit enters a closed mesh
    /// through a shared edge or vertex, which the union of its triangles decides robustly).
    bool hit_robust = false;
    /// Which object is hit first is outside the bands.
    bool object_robust = false;
    /// The first robust hit is on a closed mesh (missing it is a leak).
    bool first_on_closed = false;
    Quad t_first_robust = 0;  ///< t of the first robust crossing (valid when hit_robust && hit)
    std::vector<RefCrossing> crossings;  ///< reference_crossings(), for matching engine hits
};

/// Classifies crossings found with bands at least as wide as `bands` (crossings outside
/// `bands` are dropped first), so that one quad evaluation serves several band sets.
RefAnswer classify(const std::vector<RefCrossing>& crossings, const engine::Ray& ray,
                   const Bands& bands, const std::vector<bool>& closed);

/// `closed[i]` says whether object i is a closed mesh (every edge shared by exactly two
/// triangles); it may be shorter than the object list (missing entries: not closed).
RefAnswer reference_closest(const engine::Scene& scene, const engine::Ray& ray, const Bands& bands,
                            const std::vector<bool>& closed);

/// True when every edge of the mesh is used by exactly two of its triangles, once in each
/// direction (a closed, consistently oriented 2-manifold).
bool is_closed_mesh(const engine::TriangleMesh& mesh);

/// The unit in the last place of a double: the gap between |x| and the next double away from 0.
double ulp(double x);

/// quad → double, rounded to nearest.
inline double to_double(Quad q) {
    return static_cast<double>(q);
}

}  // namespace raycastd::stress
