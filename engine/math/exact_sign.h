#pragma once
// The exact sign of a ray/edge orientation, for the few decisions double cannot settle.
//
// Woop's edge functions (engine/geometry/triangle.cpp) are the 2-D cross products of the
// triangle's corners sheared along the ray, and their sign is the sign of the triple product
// ((p − o) × (q − o))·d for the edge's corners p, q, the ray's origin o and direction d. In
// double they are decided wherever they exceed their rounding bound; the rest come here, where
// the triple product is formed without rounding: each difference as an exact pair (TwoSum),
// each product of two doubles exactly (TwoProduct), and the 96 resulting doubles summed into
// a nonoverlapping expansion (Shewchuk, "Adaptive Precision Floating-Point Arithmetic and Fast
// Robust Geometric Predicates", Discrete Comput. Geom. 18, 1997: GROW-EXPANSION, Theorem 10,
// with zero elimination), whose sign is that of its largest component.

#include <cmath>
#include <cstddef>

#include "engine/math/double_double.h"
#include "engine/math/vec3.h"

namespace raycastd::engine {

/// A sum of doubles held exactly as nonoverlapping components in increasing magnitude.
class Expansion {
  public:
    /// Adds b exactly (GROW-EXPANSION).
    void add(double b) {
        double q = b;
        std::size_t m = 0;
        for (std::size_t i = 0; i < n_; ++i) {
            const dd::DD s = dd::two_sum(q, e_[i]);
            q = s.hi;
            if (s.lo != 0.0)
                e_[m++] = s.lo;
        }
        if (q != 0.0)
            e_[m++] = q;
        n_ = m;
    }
    /// −1, 0 or +1: the sign of the sum.
    int sign() const { return n_ == 0 ? 0 : (e_[n_ - 1] > 0.0 ? 1 : -1); }

  private:
    static constexpr std::size_t kCapacity = 128;  // one more component per add at most
    double e_[kCapacity];
    std::size_t n_ = 0;
};

/// The sign (−1, 0, +1) of ((p − o) × (q − o))·d, exact, and whether it is: a TwoProduct is
/// exact unless its product underflows (below ~2⁻⁹⁶⁹ its rounding error is not a double) or
/// overflows, and `exact` is false when some product came near either end.
inline int triple_product_sign(const Vec3d& p, const Vec3d& q, const Vec3d& o, const Vec3d& d,
                               bool& exact) {
    dd::DD pp[3], qq[3];
    for (std::size_t k = 0; k < 3; ++k) {
        pp[k] = dd::two_sum(p[k], -o[k]);
        qq[k] = dd::two_sum(q[k], -o[k]);
    }
    exact = true;
    Expansion sum;
    // a·b exactly as two doubles, unless the product is near underflow (its rounding error is
    // then no double) or overflow: `exact` says so.
    auto product = [&](double a, double b) {
        const dd::DD ab = dd::two_prod(a, b);
        const double m = std::abs(ab.hi);
        if (a != 0.0 && b != 0.0 && !(m >= 0x1p-969 && m <= 0x1p1000))
            exact = false;
        return ab;
    };
    // x·y·z exactly as four doubles, each added with `sign`.
    auto add_product = [&](double x, double y, double z, double sign) {
        const dd::DD xy = product(x, y);
        for (const double part : {xy.hi, xy.lo}) {
            const dd::DD xyz = product(part, z);
            sum.add(sign * xyz.hi);
            sum.add(sign * xyz.lo);
        }
    };
    // (P × Q)_k · d_k = (P_i Q_j − P_j Q_i) · d_k over the cyclic (i, j, k).
    for (std::size_t k = 0; k < 3; ++k) {
        const std::size_t i = (k + 1) % 3, j = (k + 2) % 3;
        for (const double pi : {pp[i].hi, pp[i].lo})
            for (const double qj : {qq[j].hi, qq[j].lo})
                add_product(pi, qj, d[k], 1.0);
        for (const double pj : {pp[j].hi, pp[j].lo})
            for (const double qi : {qq[i].hi, qq[i].lo})
                add_product(pj, qi, d[k], -1.0);
    }
    return sum.sign();
}

}  // namespace raycastd::engine
