#pragma once
// The Phong illumination model (Phong 1975) as the tutorial writes it:
//
//   I = ka·Ia + Σ_p Ip·(kd·(N·L) + ks·(R·V)ⁿ),   R = 2(N·L)N − L,
//
// with N the unit normal facing the viewer, L the unit direction to light p, V the unit
// direction to the viewer and n the shininess. A light behind the surface (N·L ≤ 0) adds
// nothing; a highlight facing away (R·V ≤ 0) adds no specular term.

#include <cmath>

#include "engine/math/vec3.h"
#include "engine/scene/material.h"

namespace raycastd::engine {

/// The two terms one light adds at a point.
struct PhongLightTerms {
    Vec3d diffuse;   ///< Ip·kd·(N·L)
    Vec3d specular;  ///< Ip·ks·(R·V)ⁿ (zero when `with_specular` is false)
    Vec3d sum() const { return diffuse + specular; }
};

/// The ambient term ka·Ia (ka: the material's ambient colour, times its texture's where it has
/// one: shade/whitted.cpp).
inline Vec3d phong_ambient(const Vec3d& ka, const Vec3d& ia) {
    return ka * ia;
}

/// xⁿ for the specular term: by repeated squaring where the shininess n is a whole number up to
/// 1024 (right-to-left binary exponentiation, Knuth, TAOCP vol. 2, §4.6.3: at most 20
/// multiplications; each squaring doubles the relative error it inherits, so the result is
/// within ~2n·u of xⁿ, 5e-13 at most, far below what an image shows), std::pow otherwise (a glTF
/// material's 2/roughness⁴ − 2 is seldom whole). The tutorial's materials have whole shininess;
/// std::pow was 2.6% of the tutorial_like render (perf).
inline double phong_power(double x, double n) {
    if (n >= 0.0 && n <= 1024.0 && n == std::floor(n)) {
        auto k = static_cast<unsigned>(n);
        double result = 1.0, base = x;
        while (k != 0) {
            if (k & 1u)
                result *= base;
            base *= base;
            k >>= 1;
        }
        return result;
    }
    return std::pow(x, n);
}

/// The diffuse and specular terms of one light of intensity `ip` in unit direction `l` at a
/// point with unit normal `n` seen from unit direction `v`, for diffuse colour `kd`, specular
/// colour `ks` and shininess `shininess`. Zero when n·l ≤ 0. `with_specular = false` skips the
/// power for materials whose ks is zero. Inline: a renderer calls it per light per hit, and its
/// 48-byte answer, returned through memory from another file, was read back in other-sized
/// pieces by the caller (its addition into the colour was shade_batch's hottest instruction on
/// the Duck, perf annotate).
inline PhongLightTerms phong_light(const Vec3d& kd, const Vec3d& ks, double shininess,
                                   const Vec3d& n, const Vec3d& l, const Vec3d& v, const Vec3d& ip,
                                   bool with_specular) {
    PhongLightTerms out;
    const double n_dot_l = dot(n, l);
    if (!(n_dot_l > 0.0))
        return out;
    out.diffuse = ip * kd * n_dot_l;
    if (with_specular) {
        const Vec3d r = n * (2.0 * n_dot_l) - l;
        const double r_dot_v = dot(r, v);
        if (r_dot_v > 0.0)
            out.specular = ip * ks * phong_power(r_dot_v, shininess);
    }
    return out;
}

/// phong_light() with the material's own colours (a textured surface passes its kd instead:
/// shade/whitted.cpp).
inline PhongLightTerms phong_light(const Material& m, const Vec3d& n, const Vec3d& l,
                                   const Vec3d& v, const Vec3d& ip, bool with_specular) {
    return phong_light(m.diffuse, m.specular, m.shininess, n, l, v, ip, with_specular);
}

}  // namespace raycastd::engine
