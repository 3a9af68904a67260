#include "tests/stress/point_reference.h"

#include <algorithm>

#include "engine/geometry/closest_point.h"
#include "engine/geometry/solid_angle.h"
#include "tests/stress/quad_vec.h"

namespace raycastd::stress {

namespace {

/// |p − s|² for the nearest point s of the segment [s0, s0 + e].
Quad segment_distance2(const QVec& s0, const QVec& e, const QVec& p) {
    const QVec w = p - s0;
    Quad t = dot(w, e) / dot(e, e);
    t = t < 0 ? Quad(0) : (t > 1 ? Quad(1) : t);
    const QVec d = w - e * t;
    return dot(d, d);
}

/// The squared distance from p to the triangle (see the header's method).
Quad triangle_distance2(const engine::Triangle& tri, const engine::Vec3d& point) {
    const QVec a = q(tri.a), b = q(tri.b), c = q(tri.c), p = q(point);
    const QVec n = cross(b - a, c - a);
    const Quad nn = dot(n, n);
    const Quad s0 = dot(n, cross(b - a, p - a)), s1 = dot(n, cross(c - b, p - b)),
               s2 = dot(n, cross(a - c, p - c));
    if (s0 >= 0 && s1 >= 0 && s2 >= 0) {
        const Quad h = dot(n, p - a);
        return h * h / nn;
    }
    return std::min({segment_distance2(a, b - a, p), segment_distance2(b, c - b, p),
                     segment_distance2(c, a - c, p)});
}

}  // namespace

Quad reference_triangle_distance(const engine::Triangle& tri, const engine::Vec3d& p) {
    return sqrtq(triangle_distance2(tri, p));
}

Quad reference_distance(const engine::TriangleMesh& mesh, const engine::Vec3d& p) {
    std::vector<double> d(mesh.size(), engine::kInfinity);
    double best = engine::kInfinity, scale = 0;
    for (std::size_t i = 0; i < mesh.size(); ++i) {
        const engine::Triangle t = mesh.triangle(i);
        if (auto cp = engine::closest_point_on_triangle(t, p)) {
            d[i] = cp->distance;
            best = std::min(best, d[i]);
            scale = std::max(scale, cp->err);
        }
    }
    Quad out = 1e300;
    for (std::size_t i = 0; i < mesh.size(); ++i) {
        if (d[i] <= best * (1 + 1e-9) + 1e6 * scale)
            out = std::min(out, reference_triangle_distance(mesh.triangle(i), p));
    }
    return out;
}

double reference_winding(const engine::TriangleMesh& mesh, const engine::Vec3d& p) {
    double sum = 0;
    for (std::size_t i = 0; i < mesh.size(); ++i)
        sum += engine::triangle_solid_angle(mesh.triangle(i), p);
    return sum * engine::kInverseFourPi;
}

}  // namespace raycastd::stress
