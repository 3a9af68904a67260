#include "engine/explain/explain.h"

#include <cmath>

#include "engine/format.h"
#include "engine/query/intersect.h"

namespace raycastd::engine {

namespace {

std::string num(double v) {
    return format_shortest(v);
}

std::string vec(const Vec3d& v) {
    return "(" + num(v.x) + ", " + num(v.y) + ", " + num(v.z) + ")";
}

/// The ray's coordinate p + t·v as a student writes it: "0", "t", "2t", "1+t", "1-0.5t".
std::string coordinate(double p, double v) {
    if (v == 0.0)
        return num(p);
    std::string tv = v == 1.0 ? "t" : (v == -1.0 ? "-t" : num(v) + "t");
    if (p == 0.0)
        return tv;
    if (tv[0] == '-')
        return num(p) + tv;
    return num(p) + "+" + tv;
}

/// "(X-a)^2" with a sign-aware minus: "(t-10)^2", "(0+3)^2".
std::string squared_difference(const std::string& x, double a) {
    if (a < 0.0)
        return "(" + x + "+" + num(-a) + ")^2";
    return "(" + x + "-" + num(a) + ")^2";
}

std::string quadratic(double a, double b, double c) {
    auto term = [](double k, const char* var, bool first) {
        if (k == 0.0 && !first)
            return std::string();
        std::string s;
        if (!first)
            s += k < 0.0 ? " - " : " + ";
        else if (k < 0.0)
            s += "-";
        double m = std::abs(k);
        if (*var == '\0' || m != 1.0)
            s += num(m);
        return s + var;
    };
    return term(a, "t^2", true) + term(b, "t", false) + term(c, "", false) + " = 0";
}

/// The step written in place of the algebra whose numbers double cannot hold.
constexpr const char* kOutOfRange =
    "at this scale the products of these coordinates leave double precision's range (about "
    "1e-308 to 1.8e308), so they are not written out: the engine's kernels rescale the "
    "coordinates by a power of two first and decide";

/// The reason given for a sphere sphere_roots cannot resolve (SphereRoots::unresolved).
constexpr const char* kUnresolved =
    "the sphere's radius is below 2^-900 of its distance from the ray's origin (or of the "
    "origin's coordinates): double precision cannot tell there whether the line passes within "
    "it, and every precision takes it as missed";

/// The reason given for a crossing whose t is past double's largest value.
constexpr const char* kTBeyondRange =
    "the ray crosses it at a t beyond double precision's range (about 1.8e308): not a hit that "
    "can be reported";

/// Below this a square (A = |v|²) has lost digits to the subnormal range.
constexpr double kSmallestSquare = 0x1p-1000;

ObjectWork work_sphere(const Sphere& s, const Ray& ray) {
    ObjectWork w;
    const Vec3d& p = ray.origin;
    const Vec3d& v = ray.direction;
    const Vec3d& c = s.center;
    w.steps.push_back("l(t) = " + vec(p) + " + t*" + vec(v));
    w.steps.push_back(squared_difference("x", c.x) + "+" + squared_difference("y", c.y) + "+" +
                      squared_difference("z", c.z) + " = " + num(s.radius) + "^2");
    w.steps.push_back(squared_difference(coordinate(p.x, v.x), c.x) + "+" +
                      squared_difference(coordinate(p.y, v.y), c.y) + "+" +
                      squared_difference(coordinate(p.z, v.z), c.z) + " = " + num(s.radius) + "^2");
    SphereWork sw;
    const Vec3d f = p - c;
    sw.a = dot(v, v);
    sw.b = 2.0 * dot(f, v);
    sw.c = dot(f, f) - s.radius * s.radius;
    // B² − 4AC = 4A·(r − |l|)(r + |l|), l the closest-approach offset (see geometry/sphere.h):
    // the same value the intersector decides on, without cancellation.
    const Vec3d l = f - v * (dot(f, v) / sw.a);
    const double len_l = length(l);
    sw.discriminant = 4.0 * sw.a * ((s.radius - len_l) * (s.radius + len_l));
    // Past ~1e154 (or below ~1e-154) the squares leave double's range: written out they were
    // "inf" and "nan". The roots do not need them: sphere_roots scales lengths first.
    // A discriminant that underflowed (a sphere of radius 1e-300: 4e-600 written as 0, beside
    // roots or a miss that contradict it) is out of range too; an exact 0 (r = |l|) is not.
    const bool disc_in_range =
        sw.discriminant == 0.0 ? s.radius == len_l : std::abs(sw.discriminant) >= kSmallestSquare;
    sw.representable = std::isfinite(sw.a) && std::isfinite(sw.b) && std::isfinite(sw.c) &&
                       std::isfinite(sw.discriminant) && sw.a >= kSmallestSquare && disc_in_range;
    if (sw.representable) {
        w.steps.push_back(quadratic(sw.a, sw.b, sw.c));
        w.steps.push_back("discriminant B^2-4AC = " + num(sw.discriminant));
    } else {
        w.steps.push_back(kOutOfRange);
    }

    const SphereRoots r = sphere_roots(s, ray);
    // A direction far shorter than the distances (1e-150 against 1e200) makes a root overflow.
    // Only the finite ones can be reported: a ray from inside a sphere 1e300 across, 4e-9 long,
    // has its root behind at -inf and the one ahead at 1.25e308, which is the intersectors' hit
    // (their kernels skip a root past the largest double, not the other one).
    int overflowed = 0;
    for (int i = 0; i < r.count; ++i) {
        if (std::isfinite(r.t[i]))
            sw.roots.push_back(r.t[i]);
        else
            ++overflowed;
    }
    if (r.count == 0 && r.unresolved) {
        w.reason = kUnresolved;
        w.steps.push_back(w.reason);
    } else if (r.count == 0) {
        w.reason = "no real roots: the ray misses";
        w.steps.push_back(w.reason);
    } else if (sw.roots.empty()) {
        w.reason = kTBeyondRange;
        w.steps.push_back(w.reason);
    } else {
        if (r.count == 1)
            w.steps.push_back("t = " + num(sw.roots[0]) + " (tangent)");
        else if (overflowed == 0)
            w.steps.push_back("t = " + num(sw.roots[0]) + " or t = " + num(sw.roots[1]));
        else
            w.steps.push_back("t = " + num(sw.roots[0]) +
                              " (the other root lies beyond double precision's range, about "
                              "1.8e308)");
        for (double t : sw.roots) {
            if (t >= ray.tmin && t <= ray.tmax) {
                w.hit = true;
                w.t = t;
                break;
            }
        }
        if (!w.hit) {
            w.reason = sw.roots.size() == 2 ? "both roots lie outside [tmin, tmax]: the ray misses"
                       : r.count == 1       ? "the root lies outside [tmin, tmax]: the ray misses"
                                      : "the finite root lies outside [tmin, tmax]: the ray misses";
            w.steps.push_back(w.reason);
        }
    }
    w.sphere = sw;
    return w;
}

ObjectWork work_triangle(const Triangle& tri, const Ray& ray) {
    ObjectWork w;
    TriangleWork tw;
    const Vec3d& p = ray.origin;
    const Vec3d& v = ray.direction;
    // Step 1: the plane ⟨n,x⟩ = ⟨n,a⟩ with n = ac × ab (tutorial, Question 3).
    tw.normal = cross(tri.c - tri.a, tri.b - tri.a);
    tw.plane_d = dot(tw.normal, tri.a);
    tw.n_dot_v = dot(tw.normal, v);
    w.steps.push_back("l(t) = " + vec(p) + " + t*" + vec(v));
    // n and ⟨n,a⟩ are products of two and three coordinates: past ~1e102 (or for edges below
    // ~1e-150) they overflow or underflow, and the plane method's numbers were inf, nan or a
    // zero normal; t overflows for a direction far shorter than the distances (1e-150 against
    // 1e200), and the cross products for points past ~1e154. Every number is formed first, and
    // where one is not finite the watertight test (which rescales) decides instead.
    const double magnitude = std::abs(tw.normal.x) + std::abs(tw.normal.y) + std::abs(tw.normal.z);
    tw.representable = std::isfinite(tw.plane_d) && std::isfinite(dot(tw.normal, p)) &&
                       std::isfinite(tw.n_dot_v) && std::isfinite(magnitude * max_abs(v)) &&
                       (magnitude >= kSmallestSquare || is_degenerate(tri));
    // Step 2, substituting l(t): ⟨n,p⟩ + t·⟨n,v⟩ = ⟨n,a⟩, gives t and d = l(t). Step 3: d is
    // inside iff da×db, db×dc, dc×da point the same way (pairwise dot ≥ 0; a zero vector, d on
    // an edge line, agrees with any direction). Worked here, written out below.
    double dots[3] = {0.0, 0.0, 0.0};
    if (tw.representable && magnitude > 0.0 && tw.n_dot_v != 0.0) {
        tw.t = (tw.plane_d - dot(tw.normal, p)) / tw.n_dot_v;
        tw.point = ray.at(*tw.t);
        const Vec3d& d = *tw.point;
        const Vec3d da = tri.a - d, db = tri.b - d, dc = tri.c - d;
        tw.cross[0] = cross(da, db);
        tw.cross[1] = cross(db, dc);
        tw.cross[2] = cross(dc, da);
        for (int k = 0; k < 3; ++k)
            dots[k] = dot(tw.cross[k], tw.cross[(k + 1) % 3]);
        tw.representable = std::isfinite(*tw.t) && is_finite(d) && is_finite(tw.cross[0]) &&
                           is_finite(tw.cross[1]) && is_finite(tw.cross[2]) &&
                           std::isfinite(dots[0]) && std::isfinite(dots[1]) &&
                           std::isfinite(dots[2]);
    }
    if (!tw.representable) {
        tw.t.reset();
        tw.point.reset();
        tw.cross[0] = tw.cross[1] = tw.cross[2] = Vec3d{};
        w.steps.push_back(kOutOfRange);
        const std::optional<Hit> h = intersect_triangle(tri, ray, false);
        if (h && std::isfinite(h->t)) {
            w.hit = true;
            w.t = h->t;
            tw.t = h->t;
            tw.point = ray.at(h->t);
            w.steps.push_back("the watertight test: hit at t = " + num(h->t));
        } else {
            w.reason = h ? kTBeyondRange : "the watertight test: the ray misses";
            w.steps.push_back(w.reason);
        }
        w.triangle = tw;
        return w;
    }
    w.steps.push_back("n = ac x ab = " + vec(tw.normal));
    w.steps.push_back("plane: <n,x> = <n,a> = " + num(tw.plane_d));
    if (tw.normal == Vec3d{0.0, 0.0, 0.0}) {
        w.reason = "degenerate triangle (n = 0): never hit";
        w.steps.push_back(w.reason);
        w.triangle = tw;
        return w;
    }
    if (tw.n_dot_v == 0.0) {
        w.reason = "<n,v> = 0: the ray is parallel to the plane and misses";
        w.steps.push_back(w.reason);
        w.triangle = tw;
        return w;
    }
    const double t = *tw.t;
    w.steps.push_back("<n,p> + t<n,v> = <n,a>  =>  t = " + num(t));
    w.steps.push_back("d = l(t) = " + vec(*tw.point));
    tw.same_direction = dots[0] >= 0.0 && dots[1] >= 0.0 && dots[2] >= 0.0;
    w.steps.push_back("da x db = " + vec(tw.cross[0]) + ", db x dc = " + vec(tw.cross[1]) +
                      ", dc x da = " + vec(tw.cross[2]));
    if (!tw.same_direction) {
        w.reason = "the cross products do not point the same way: d is outside abc";
    } else if (!(t >= ray.tmin && t <= ray.tmax)) {
        w.reason = "d is inside abc but t lies outside [tmin, tmax]: the ray misses";
    } else {
        w.hit = true;
        w.t = t;
    }
    w.steps.push_back(w.hit ? "same direction: d is inside abc, hit at t = " + num(t) : w.reason);
    w.triangle = tw;
    return w;
}

}  // namespace

Result<Explanation> explain(const Scene& scene, const Ray& ray, const CancelToken& cancel) {
    Explanation ex;
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        if (cancel.cancelled())
            return cancel.status();
        const Object& o = scene.objects[i];
        ObjectWork w;
        if (o.kind == ObjectKind::sphere) {
            w = work_sphere(o.sphere, ray);
        } else if (o.kind == ObjectKind::triangle) {
            w = work_triangle(o.mesh->triangle(0), ray);
        } else {
            // A mesh has too many triangles for hand algebra: report the engine's answer.
            w.triangles = o.mesh->size();
            w.steps.push_back("mesh of " + std::to_string(w.triangles) +
                              " triangles, each tested with the watertight ray/triangle test");
            if (auto h = closest_in_object_by_brute_force(scene, i, ray, false, cancel)) {
                w.hit = true;
                w.t = h->t;
                w.steps.push_back("closest hit: triangle " + std::to_string(h->primitive) +
                                  " at t = " + num(h->t));
            } else {
                w.reason = "no triangle of the mesh is hit";
                w.steps.push_back(w.reason);
            }
        }
        w.index = i;
        w.name = o.name;
        w.kind = o.kind;
        ex.objects.push_back(std::move(w));
    }
    ex.first_hit = closest_by_brute_force(scene, ray, true, cancel);
    if (ex.first_hit && !std::isfinite(ex.first_hit->t))
        ex.first_hit.reset();  // past double's range (the objects' steps say so)
    if (cancel.fired())
        return cancel.status();
    if (ex.first_hit)
        ex.first_point = hit_point(scene, ray, *ex.first_hit);  // l(t), or on the surface from afar
    return ex;
}

}  // namespace raycastd::engine
