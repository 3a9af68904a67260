#pragma once
// Double-double arithmetic for the kernels that need more than double precision in a few
// steps: a value is the unevaluated sum hi + lo of two doubles (Dekker 1971; Knuth, TAOCP
// vol. 2, §4.2.2). TwoSum and TwoProduct (with a fused multiply-add; Ogita, Rump & Oishi 2005)
// are exact; the sums and products built on them carry a relative error of a few u² (u = 2⁻⁵³)
// of their operands, which is all the kernels need: every quantity formed this way is used
// once, then rounded to double.

#include <cmath>

namespace raycastd::engine::dd {

struct DD {
    double hi = 0.0, lo = 0.0;
};

/// a + b = s + e exactly (Knuth's TwoSum: no condition on the magnitudes).
inline DD two_sum(double a, double b) {
    const double s = a + b;
    const double bb = s - a;
    return {s, (a - (s - bb)) + (b - bb)};
}
/// a + b = s + e exactly when |a| ≥ |b| (Dekker's FastTwoSum).
inline DD fast_two_sum(double a, double b) {
    const double s = a + b;
    return {s, b - (s - a)};
}
/// a·b = p + e exactly (TwoProduct with a fused multiply-add).
inline DD two_prod(double a, double b) {
    const double p = a * b;
    return {p, std::fma(a, b, -p)};
}
inline DD add(DD a, DD b) {
    const DD s = two_sum(a.hi, b.hi);
    return fast_two_sum(s.hi, s.lo + (a.lo + b.lo));
}
inline DD neg(DD a) {
    return {-a.hi, -a.lo};
}
inline DD sub(DD a, DD b) {
    return add(a, neg(b));
}
inline DD mul(DD a, double b) {
    const DD p = two_prod(a.hi, b);
    return fast_two_sum(p.hi, std::fma(a.lo, b, p.lo));
}
inline DD mul(DD a, DD b) {
    const DD p = two_prod(a.hi, b.hi);
    return fast_two_sum(p.hi, p.lo + (a.hi * b.lo + a.lo * b.hi));
}
/// n / d rounded to double (one correction step: the residual n − t·d is formed exactly).
inline double div(DD n, DD d) {
    const double t = n.hi / d.hi;
    const DD p = two_prod(t, d.hi);
    const double r = ((n.hi - p.hi) - p.lo) + n.lo - t * d.lo;
    return t + r / d.hi;
}
/// √x of a non-negative x, to a few u² (one Newton step on the double square root).
inline DD sqrt_dd(DD x) {
    const double s = std::sqrt(x.hi);
    const DD p = two_prod(s, s);
    return fast_two_sum(s, (((x.hi - p.hi) - p.lo) + x.lo) / (2.0 * s));
}

}  // namespace raycastd::engine::dd
