#include "engine/accel/linear_accel.h"

#include <algorithm>
#include <cmath>

namespace raycastd::engine {

std::optional<Hit> linear_closest_in_object(const Scene& scene, std::uint32_t object,
                                            const Ray& ray_in, bool want_normal,
                                            const CancelToken* cancel) {
    const Object& o = scene.objects[object];
    std::optional<Hit> best;
    if (o.kind == ObjectKind::sphere) {
        best = intersect_sphere(o.sphere, ray_in, want_normal);
    } else {
        Ray ray = ray_in;
        const TriangleMesh& mesh = *o.mesh;
        for (std::size_t b = 0; b < mesh.size(); b += kLinearCancelStride) {
            if (cancel && cancel->cancelled())
                return std::nullopt;
            const std::size_t e = std::min(mesh.size(), b + kLinearCancelStride);
            for (std::size_t p = b; p < e; ++p) {
                auto h = intersect_triangle(mesh.triangle(p), ray, want_normal);
                // Strictly closer only: an exact tie keeps the lower primitive index.
                if (h && (!best || h->t < best->t)) {
                    h->primitive = static_cast<std::uint32_t>(p);
                    best = h;
                    ray.tmax = h->t;
                }
            }
        }
    }
    if (best)
        best->object = object;
    return best;
}

std::optional<Hit> linear_closest(const Scene& scene, const Ray& ray_in, bool want_normal,
                                  const CancelToken* cancel) {
    Ray ray = ray_in;
    std::optional<Hit> best;
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        auto h = linear_closest_in_object(scene, i, ray, want_normal, cancel);
        if (cancel && cancel->fired())
            return std::nullopt;
        if (h && (!best || closer(*h, *best))) {
            best = h;
            ray.tmax = h->t;  // inclusive, so an exact tie with a later object is still seen
        }
    }
    return best;
}

void sort_and_merge_edge_duplicates(std::vector<Hit>& hits) {
    // Stable: a sphere's two roots that round to one t tie by `closer`, and stay in the order
    // they were appended, entry first (std::sort put the exit first in 25 of 72 such lines from
    // 2^30 away: a review).
    std::stable_sort(hits.begin(), hits.end(), closer);
    std::vector<std::size_t> order(hits.size());
    for (std::size_t k = 0; k < order.size(); ++k)
        order[k] = k;
    const std::vector<std::size_t> kept =
        kept_after_edge_merge(order, [&](std::size_t k) -> const Hit& { return hits[k]; });
    std::vector<Hit> merged;
    merged.reserve(kept.size());
    for (const std::size_t k : kept)
        merged.push_back(hits[k]);
    hits.swap(merged);
}

namespace {

/// Every crossing of object i by `ray`, appended to `out` (unsorted).
void append_hits(const Scene& scene, std::uint32_t i, const Ray& ray, bool want_normal,
                 std::vector<Hit>& out) {
    const Object& o = scene.objects[i];
    if (o.kind == ObjectKind::sphere) {
        Hit hits[2];
        const int n = sphere_hits(o.sphere, ray, hits);  // front_face is needed for merging
        for (int k = 0; k < n; ++k) {
            hits[k].object = i;
            if (!want_normal)
                hits[k].normal = Vec3d{};  // not asked, not answered
            out.push_back(hits[k]);
        }
        return;
    }
    for (std::size_t p = 0; p < o.mesh->size(); ++p) {
        if (auto h = intersect_triangle(o.mesh->triangle(p), ray, want_normal)) {
            h->object = i;
            h->primitive = static_cast<std::uint32_t>(p);
            out.push_back(*h);
        }
    }
}

/// Whether `ray` hits object o in [tmin, tmax].
bool hits_object(const Object& o, const Ray& ray) {
    if (o.kind == ObjectKind::sphere)
        return intersect_sphere(o.sphere, ray, false).has_value();
    for (std::size_t p = 0; p < o.mesh->size(); ++p) {
        if (decide_triangle(o.mesh->triangle(p), ray))  // intersect_triangle's decision
            return true;
    }
    return false;
}

// A far ray's meshes are answered on the ray moved to the scene (the *_from_afar functions).
// A sphere is decided on the client's ray: its kernel forms o − c in double-double and loses
// nothing to the distance, while the moved origin rounds by u·|origin| (a helper's review of
// the first version, which moved spheres too: near-tangent lines 1e-10 of a radius outside a
// sphere at (1e6, 2e6, 3e6) were hit, and 55–67 of 400 near-tangent lines at a sphere 1e-6
// across were decided wrongly, where the unmoved kernel had been right). Crossings of both kinds
// are ordered by their places on the moved ray (`closest` below, `all` by
// sort_and_merge_on_moved): from far enough every client t rounds to one double.

/// linear_any's loop, each mesh tested on `mesh_ray` (the ray itself, or it moved).
bool any_hit(const Scene& scene, const Ray& ray, const Ray& mesh_ray) {
    for (const Object& o : scene.objects) {
        if (hits_object(o, o.kind == ObjectKind::sphere ? ray : mesh_ray))
            return true;
    }
    return false;
}

/// linear_all's loop, each mesh's crossings taken on m->ray and mapped back where `m` is given,
/// and then listed in their order along the moved ray (sort_and_merge_on_moved), each sphere's
/// at its place there (sphere_on_moved).
void all_hits(const Scene& scene, const Ray& ray, const MovedRay* m, bool want_normal,
              std::vector<Hit>& out) {
    out.clear();
    if (!m) {
        for (std::uint32_t i = 0; i < scene.objects.size(); ++i)
            append_hits(scene, i, ray, want_normal, out);
        sort_and_merge_edge_duplicates(out);  // by `closer` on the client's t
        return;
    }
    std::vector<Hit> moved;
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        const Object& o = scene.objects[i];
        const std::size_t first = out.size();
        if (o.kind == ObjectKind::sphere) {
            append_hits(scene, i, ray, want_normal, out);
            Hit on_moved[2];
            const int n_moved = sphere_hits(o.sphere, m->ray, on_moved);
            const int n = static_cast<int>(out.size() - first);
            for (int k = 0; k < n; ++k)
                moved.push_back(
                    sphere_on_moved(o.sphere, *m, m->ray, out[first + k], k, n, on_moved, n_moved));
            continue;
        }
        append_hits(scene, i, m->ray, want_normal, out);
        for (std::size_t k = first; k < out.size(); ++k) {
            moved.push_back(out[k]);
            moved_back(scene, *m, out[k]);
        }
    }
    sort_and_merge_on_moved(moved, out);
}

/// A far ray moved to the scene for its meshes (far_ray.h, world coordinates).
struct FarMove {
    bool moved = false;   ///< `m` holds the moved ray
    bool misses = false;  ///< the line passes outside the scene's ball: nothing is hit
    MovedRay m;
};

FarMove far_move(const SceneBall& ball, const Ray& ray) {
    FarMove f;
    if (ball.far(ray)) {
        switch (move_near_ball_world(ball.centre, ball.radius, ray, f.m)) {
            case MoveResult::misses:
                f.misses = true;
                break;
            case MoveResult::moved:
                f.moved = true;
                break;
            case MoveResult::not_possible:
                break;
        }
    }
    return f;
}

}  // namespace

bool linear_any(const Scene& scene, const Ray& ray) {
    return any_hit(scene, ray, ray);
}

void linear_all(const Scene& scene, const Ray& ray, bool want_normal, std::vector<Hit>& out) {
    all_hits(scene, ray, nullptr, want_normal, out);
}

std::optional<Hit> linear_closest_from_afar(const Scene& scene, const SceneBall& ball,
                                            const Ray& ray, bool want_normal,
                                            const CancelToken* cancel) {
    const FarMove f = far_move(ball, ray);
    if (f.misses)
        return std::nullopt;
    if (!f.moved)
        return linear_closest(scene, ray, want_normal, cancel);
    // Objects are ordered by their first crossing's t on the moved ray, not by the client's t:
    // from far enough every crossing's t rounds to one double (its ulp is 128 from 1e18 away),
    // and `closer` then gave the hit to the lowest object, in front or not. A sphere, decided on
    // the client's ray, is placed by its root on the moved ray (or, where that kernel misses a
    // line within the move's error of tangency, by the moved ray's closest approach to its
    // centre: the client's root carried over, rounded by ~u·distance, had put a sphere behind a
    // cube 3e-3 beyond it in 81 of 1,000 such lines from 2^50–2^56 away, a helper's review).
    std::optional<Hit> best;
    double best_key = 0.0;
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
        const bool sphere = scene.objects[i].kind == ObjectKind::sphere;
        std::optional<Hit> h =
            linear_closest_in_object(scene, i, sphere ? ray : f.m.ray, want_normal, cancel);
        if (cancel && cancel->fired())
            return std::nullopt;
        if (!h)
            continue;
        double key = h->t;
        if (sphere) {
            // Placed as `all` places it (sphere_on_moved): its first root in range is root 0 of
            // the client's roots in range.
            const Sphere& sp = scene.objects[i].sphere;
            Hit in_range[2], on_moved[2];
            const int n = sphere_hits(sp, ray, in_range);
            const int n_moved = sphere_hits(sp, f.m.ray, on_moved);
            key = sphere_on_moved(sp, f.m, f.m.ray, *h, 0, n, on_moved, n_moved).t;
        } else {
            moved_back(scene, f.m, *h);
        }
        if (!best || key < best_key) {  // objects come in order: a tie keeps the lower one
            best = h;
            best_key = key;
        }
    }
    // Its t overflowed double on the way back (moved_back), and every other crossing lies
    // beyond it: no hit (sphere.h, first_root_in_range).
    if (best && !std::isfinite(best->t))
        return std::nullopt;
    return best;
}

bool linear_any_from_afar(const Scene& scene, const SceneBall& ball, const Ray& ray) {
    const FarMove f = far_move(ball, ray);
    return !f.misses && any_hit(scene, ray, f.moved ? f.m.ray : ray);
}

void linear_all_from_afar(const Scene& scene, const SceneBall& ball, const Ray& ray,
                          bool want_normal, std::vector<Hit>& out) {
    const FarMove f = far_move(ball, ray);
    if (f.misses) {
        out.clear();
        return;
    }
    all_hits(scene, ray, f.moved ? &f.m : nullptr, want_normal, out);
}

}  // namespace raycastd::engine
