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

bool linear_any(const Scene& scene, const Ray& ray) {
    for (const Object& o : scene.objects) {
        if (o.kind == ObjectKind::sphere) {
            if (intersect_sphere(o.sphere, ray, false))
                return true;
            continue;
        }
        for (std::size_t p = 0; p < o.mesh->size(); ++p) {
            if (intersect_triangle(o.mesh->triangle(p), ray, false))
                return true;
        }
    }
    return false;
}

void sort_and_merge_edge_duplicates(std::vector<Hit>& hits) {
    std::sort(hits.begin(), hits.end(), closer);
    std::vector<Hit> kept;
    kept.reserve(hits.size());
    for (const Hit& h : hits) {
        bool duplicate = false;
        if (h.on_edge) {
            // Hits sorted by t: only the tail of `kept` can be within the error band.
            for (auto it = kept.rbegin(); it != kept.rend(); ++it) {
                if (h.t - it->t > h.t_err + it->t_err)
                    break;
                if (it->object == h.object && it->on_edge && it->front_face == h.front_face) {
                    duplicate = true;
                    break;
                }
            }
        }
        if (!duplicate)
            kept.push_back(h);
    }
    hits.swap(kept);
}

void linear_all(const Scene& scene, const Ray& ray, bool want_normal, std::vector<Hit>& out) {
    out.clear();
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i) {
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
            continue;
        }
        for (std::size_t p = 0; p < o.mesh->size(); ++p) {
            if (auto h = intersect_triangle(o.mesh->triangle(p), ray, want_normal)) {
                h->object = i;
                h->primitive = static_cast<std::uint32_t>(p);
                out.push_back(*h);
            }
        }
    }
    sort_and_merge_edge_duplicates(out);
}

std::optional<Hit> linear_closest_from_afar(const Scene& scene, const SceneBall& ball,
                                            const Ray& ray, bool want_normal,
                                            const CancelToken* cancel) {
    MovedRay m;
    if (ball.far(ray)) {
        switch (move_near_ball_world(ball.centre, ball.radius, ray, m)) {
            case MoveResult::misses:
                return std::nullopt;
            case MoveResult::moved: {
                std::optional<Hit> h = linear_closest(scene, m.ray, want_normal, cancel);
                if (h)
                    moved_back(scene, m, *h);
                return h;
            }
            case MoveResult::not_possible:
                break;
        }
    }
    return linear_closest(scene, ray, want_normal, cancel);
}

bool linear_any_from_afar(const Scene& scene, const SceneBall& ball, const Ray& ray) {
    MovedRay m;
    if (ball.far(ray)) {
        switch (move_near_ball_world(ball.centre, ball.radius, ray, m)) {
            case MoveResult::misses:
                return false;
            case MoveResult::moved:
                return linear_any(scene, m.ray);
            case MoveResult::not_possible:
                break;
        }
    }
    return linear_any(scene, ray);
}

void linear_all_from_afar(const Scene& scene, const SceneBall& ball, const Ray& ray,
                          bool want_normal, std::vector<Hit>& out) {
    MovedRay m;
    if (ball.far(ray)) {
        switch (move_near_ball_world(ball.centre, ball.radius, ray, m)) {
            case MoveResult::misses:
                out.clear();
                return;
            case MoveResult::moved:
                // The map back is monotonic in t (one rounding of shift + t'), so the order of
                // linear_all's hits stands.
                linear_all(scene, m.ray, want_normal, out);
                for (Hit& h : out)
                    moved_back(scene, m, h);
                return;
            case MoveResult::not_possible:
                break;
        }
    }
    linear_all(scene, ray, want_normal, out);
}

}  // namespace raycastd::engine
