#include "engine/points/inside.h"

#include <algorithm>

#include "engine/points/batch.h"

namespace raycastd::engine {

namespace {

/// The two fixed directions a parity ray is cast along again when it touched an edge or a
/// vertex: unit vectors with no zero or repeated component, so that they lie in no axis-aligned
/// plane and, in practice, in no modelled face's plane.
const Vec3d kRetryDirections[2] = {normalize(Vec3d{0.2838723, 0.8412297, -0.4601939}),
                                   normalize(Vec3d{-0.7140236, 0.1907347, 0.6735291})};

/// What one parity ray says: whether it crossed some parity mesh an odd number of times, and
/// whether any of its crossings of a parity mesh was at an edge or a vertex.
struct RayVerdict {
    bool odd = false;
    bool edge = false;
};

/// The crossings of each parity object along one ray's hits (sorted by t; any object).
RayVerdict verdict(const Hit* begin, const Hit* end, const std::vector<std::uint8_t>& parity) {
    RayVerdict v;
    // Few objects are crossed by one ray: a small list of (object, crossings).
    std::pair<std::uint32_t, std::uint32_t> counts[8];
    int used = 0;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> more;
    for (const Hit* h = begin; h != end; ++h) {
        if (!parity[h->object])
            continue;
        v.edge = v.edge || h->on_edge;
        auto* slot =
            std::find_if(counts, counts + used, [&](auto& c) { return c.first == h->object; });
        if (slot != counts + used) {
            ++slot->second;
        } else if (used < 8) {
            counts[used++] = {h->object, 1};
        } else {
            auto it = std::find_if(more.begin(), more.end(),
                                   [&](auto& c) { return c.first == h->object; });
            if (it != more.end()) {
                ++it->second;
            } else {
                more.push_back({h->object, 1});
            }
        }
    }
    for (int k = 0; k < used; ++k)
        v.odd = v.odd || (counts[k].second & 1u);
    for (const auto& c : more)
        v.odd = v.odd || (c.second & 1u);
    return v;
}

/// Casts one ray per listed point (direction dir(i)) on the exact path and returns the verdicts
/// (empty once `cancel` has fired).
template <class Dir>
std::vector<RayVerdict> cast(const QueryEngine& engine, const Vec3d* points,
                             const std::vector<std::size_t>& which, Dir&& dir,
                             const std::vector<std::uint8_t>& parity, const CancelToken& cancel) {
    std::vector<Ray> rays(which.size());
    for (std::size_t j = 0; j < which.size(); ++j)
        rays[j] = Ray{points[which[j]], dir(which[j]), 0.0, kInfinity};
    QueryOptions opt;
    opt.mode = Mode::all;
    opt.precision = Precision::exact;
    opt.want_normal = false;
    opt.cancel = cancel;
    QueryResult r;
    if (!engine.intersect(rays, opt, r).ok())
        return {};
    std::vector<RayVerdict> out(which.size());
    for (std::size_t j = 0; j < which.size(); ++j) {
        out[j] = verdict(r.hits.data() + r.offsets[j], r.hits.data() + r.offsets[j + 1], parity);
    }
    return out;
}

/// Inside by crossing parity for the listed points: the first ray away from the nearest surface
/// point, then the retries of the file comment for rays that met an edge.
void parity_inside(const QueryEngine& engine, const Vec3d* points, const PointHit* nearest,
                   const std::vector<std::size_t>& which, const std::vector<std::uint8_t>& parity,
                   const CancelToken& cancel, Occupancy* out) {
    auto away = [&](std::size_t i) {
        const Vec3d d = normalize(points[i] - nearest[i].point);
        return d == Vec3d{} ? kRetryDirections[0] : d;
    };
    const std::vector<RayVerdict> first = cast(engine, points, which, away, parity, cancel);
    if (cancel.fired())
        return;
    std::vector<std::size_t> again;
    std::vector<int> votes;
    for (std::size_t j = 0; j < which.size(); ++j) {
        if (!first[j].edge) {
            if (first[j].odd) {
                out[which[j]].inside = true;
                out[which[j]].winding = 1.0;
            }
        } else {
            again.push_back(which[j]);
            votes.push_back(first[j].odd);
        }
    }
    for (const Vec3d& d : kRetryDirections) {
        if (again.empty())
            return;
        const bool last = &d == &kRetryDirections[1];
        const std::vector<RayVerdict> v = cast(
            engine, points, again, [&](std::size_t) { return d; }, parity, cancel);
        if (cancel.fired())
            return;
        std::vector<std::size_t> next;
        std::vector<int> next_votes;
        for (std::size_t j = 0; j < again.size(); ++j) {
            const int total = votes[j] + v[j].odd;
            // A clean ray decides; after the third, two votes of three do.
            const bool inside = !v[j].edge ? v[j].odd : (last ? total >= 2 : false);
            if (v[j].edge && !last) {
                next.push_back(again[j]);
                next_votes.push_back(total);
                continue;
            }
            if (inside) {
                out[again[j]].inside = true;
                out[again[j]].winding = 1.0;
            }
        }
        again.swap(next);
        votes.swap(next_votes);
    }
}

}  // namespace

Status classify_points(const QueryEngine& engine, const Vec3d* points, const PointHit* nearest,
                       std::size_t n, bool all_objects, const CancelToken& cancel, Occupancy* out,
                       const std::vector<std::uint32_t>& order) {
    const Scene& s = engine.scene();
    const std::vector<MeshTopology>& topo = engine.topology();
    std::vector<std::uint32_t> spheres, windings;
    std::vector<std::uint8_t> parity(s.objects.size(), 0);
    for (std::uint32_t i = 0; i < s.objects.size(); ++i) {
        const Object& o = s.objects[i];
        if (o.kind == ObjectKind::sphere) {
            spheres.push_back(i);
        } else if (topo[i].sign == SignMethod::parity) {
            parity[i] = 1;
        } else {
            windings.push_back(i);
        }
    }
    const bool any_parity = std::find(parity.begin(), parity.end(), 1) != parity.end();
    // On a surface, then spheres: exact and cheap, point by point.
    // The winding number is the largest over the objects; with only winding meshes it may be
    // negative (a mesh facing inwards), so it starts at the lowest value an object can give.
    const double no_winding = spheres.empty() && !any_parity ? -kInfinity : 0.0;
    for_each_point(n, cancel, order, [&](std::size_t i) {
        out[i] = Occupancy{false, no_winding};
        if (on_surface(nearest[i])) {
            out[i] = Occupancy{true, 1.0};
            return;
        }
        for (std::uint32_t k : spheres) {
            const Sphere& sp = s.objects[k].sphere;
            const Vec3d f = points[i] - sp.center;
            if (dot(f, f) < sp.radius * sp.radius) {
                out[i] = Occupancy{true, 1.0};
                if (!all_objects)
                    return;
            }
        }
    });
    auto open = [&](std::size_t i) {
        return nearest[i].valid() && !on_surface(nearest[i]) && (all_objects || !out[i].inside);
    };
    if (any_parity) {
        std::vector<std::size_t> which;
        for (std::size_t k = 0; k < n; ++k) {
            const std::size_t i = order.empty() ? k : order[k];
            if (open(i))
                which.push_back(i);
        }
        parity_inside(engine, points, nearest, which, parity, cancel, out);
    }
    if (cancel.fired())
        return cancel.status();
    for_each_point(n, cancel, order, [&](std::size_t i) {
        if (!open(i) || windings.empty()) {
            if (out[i].winding == -kInfinity)
                out[i].winding = 0.0;  // an empty scene winds nothing
            return;
        }
        for (std::uint32_t k : windings) {
            const double w = engine.winding_number(k, points[i]);
            out[i].winding = std::max(out[i].winding, w);
            if (w >= 0.5) {
                out[i].inside = true;
                if (!all_objects)
                    return;
            }
        }
    });
    return cancel.fired() ? cancel.status() : Status{};
}

}  // namespace raycastd::engine
