#include "engine/shade/phong.h"

#include <cmath>

namespace raycastd::engine {

PhongLightTerms phong_light(const Vec3d& kd, const Vec3d& ks, double shininess, const Vec3d& n,
                            const Vec3d& l, const Vec3d& v, const Vec3d& ip, bool with_specular) {
    PhongLightTerms out;
    const double n_dot_l = dot(n, l);
    if (!(n_dot_l > 0.0))
        return out;
    out.diffuse = ip * kd * n_dot_l;
    if (with_specular) {
        const Vec3d r = n * (2.0 * n_dot_l) - l;
        const double r_dot_v = dot(r, v);
        if (r_dot_v > 0.0)
            out.specular = ip * ks * std::pow(r_dot_v, shininess);
    }
    return out;
}

}  // namespace raycastd::engine
