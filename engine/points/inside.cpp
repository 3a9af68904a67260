#include "engine/points/inside.h"

#include <algorithm>
#include <cmath>

#include <tbb/parallel_for.h>

#include "engine/points/batch.h"
#include "engine/query/parity_pieces.h"

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

/// The pieces (query/parity_pieces.h) whose boxes hold one point, in increasing order (so
/// grouped by object): up to seven in place, more (rare: nested or piled-up components) in
/// `more`.
struct HeldBy {
    static constexpr std::uint32_t kInPlace = 7;
    std::uint32_t n = 0;
    std::uint32_t in_place[kInPlace];
    std::vector<std::uint32_t> more;

    void find(const ParityPieces& pp, const Vec3d& p) {
        n = 0;
        more.clear();
        pp.grid.containing(p, [&](std::uint32_t k) {
            if (n < kInPlace) {
                in_place[n] = k;
            } else {
                if (n == kInPlace)
                    more.assign(in_place, in_place + kInPlace);
                more.push_back(k);
            }
            ++n;
        });  // in increasing order (BoxGrid::containing)
    }
    std::uint32_t* begin() { return n > kInPlace ? more.data() : in_place; }
    std::uint32_t* end() { return begin() + n; }
    const std::uint32_t* begin() const { return n > kInPlace ? more.data() : in_place; }
    const std::uint32_t* end() const { return begin() + n; }
};

/// How far a ray from p along unit d must go to leave the listed pieces' boxes widened for the
/// ray's end (ParityPieces::ray_bounds says by how much and why): the largest of their exit
/// parameters.
double reach(const ParityPieces& pp, const Vec3d& p, const Vec3d& d, const std::uint32_t* first,
             const std::uint32_t* last) {
    auto leave = [](double lo, double hi, double o, double dir) {
        if (dir > 0)
            return (hi - o) / dir;
        if (dir < 0)
            return (lo - o) / dir;
        return kInfinity;
    };
    double t_max = 0.0;
    for (const std::uint32_t* k = first; k != last; ++k) {
        const Bounds3& b = pp.ray_bounds[*k];
        const double t = std::min({leave(b.lo.x, b.hi.x, p.x, d.x), leave(b.lo.y, b.hi.y, p.y, d.y),
                                   leave(b.lo.z, b.hi.z, p.z, d.z)});
        t_max = std::max(t_max, t);
    }
    return t_max;
}

/// The crossings of the listed pieces along one ray's hits (any order; any object): per object,
/// the parity of the sum over its listed pieces (mesh/components.h); odd when some object's is.
RayVerdict verdict(const Hit* begin, const Hit* end, const ParityPieces& pp,
                   const std::uint32_t* first, const std::uint32_t* last) {
    RayVerdict v;
    const auto n = static_cast<std::size_t>(last - first);
    // A point is in few boxes: counts on the stack for up to 16 of them.
    std::uint32_t small[16] = {};
    std::vector<std::uint32_t> large(n > 16 ? n : 0, 0);
    std::uint32_t* counts = n > 16 ? large.data() : small;
    for (const Hit* h = begin; h != end; ++h) {
        if (pp.of_object[h->object].bounds.empty())
            continue;  // not a parity mesh
        // Any parity mesh's edge counts, even one of a piece left out: the all-hits path merges
        // hits of one object at one edge crossing into the hit of its lowest primitive, which
        // may be of a piece left out while the dropped one was counted (two components meeting
        // at an edge without sharing it); the ray is cast again rather than trusted.
        v.edge = v.edge || h->on_edge;
        const std::uint32_t k = pp.piece(h->object, h->primitive);
        const std::uint32_t* at = std::lower_bound(first, last, k);
        if (at == last || *at != k)
            continue;  // a piece whose box does not hold the point: its crossings cancel
        ++counts[at - first];
    }
    for (std::size_t a = 0; a < n;) {
        std::uint32_t sum = 0;
        std::size_t b = a;
        for (; b < n && pp.object[first[b]] == pp.object[first[a]]; ++b)
            sum += counts[b];
        v.odd = v.odd || (sum & 1u);
        a = b;
    }
    return v;
}

/// Points a round of cast() takes: their rays, hits and pieces stay in cache (the whole batch
/// at once page-faulted 64 MB of rays and more of hits for 1M points: 10% of a
/// signed-distance batch's samples on A's shell), while the blocks of QueryEngine::intersect
/// within a round still spread over the threads.
constexpr std::size_t kPointsPerRound = 16384;

/// The verdict of each listed point's ray (direction dir(i)), cast on the exact path as far as
/// the boxes of the pieces that hold the point reach; a point that no piece's box holds gets an
/// even, clean verdict without a ray. Empty once `cancel` has fired.
template <class Dir>
std::vector<RayVerdict> cast(const QueryEngine& engine, const Vec3d* points,
                             const std::vector<std::size_t>& which, Dir&& dir,
                             const CancelToken& cancel) {
    const ParityPieces& pp = engine.parity_pieces();
    QueryOptions opt;
    opt.mode = Mode::all;
    opt.precision = Precision::exact;
    opt.want_normal = false;
    opt.cancel = cancel;
    std::vector<RayVerdict> out(which.size());
    std::vector<HeldBy> held;
    std::vector<Ray> all;              // the round's points' rays, in its order
    std::vector<std::uint32_t> rayed;  // those (indices into the round) whose point a box holds
    std::vector<Ray> rays;
    QueryResult r;
    for (std::size_t at = 0; at < which.size(); at += kPointsPerRound) {
        const std::size_t n = std::min(kPointsPerRound, which.size() - at);
        held.resize(n);
        all.resize(n);
        // The points come in spatial order, scattered over the caller's arrays: one pass reads
        // them (and, through dir, their nearest hits) into the round's rays, and the passes
        // after it touch only the round's own arrays. The loads of successive points are
        // independent, so their cache misses overlap.
        tbb::parallel_for(std::size_t(0), n, [&](std::size_t j) {
            const std::size_t i = which[at + j];
            all[j] = Ray{points[i], dir(i), 0.0, 0.0};
        });
        tbb::parallel_for(std::size_t(0), n, [&](std::size_t j) {
            Ray& ray = all[j];
            held[j].find(pp, ray.origin);
            ray.tmax = reach(pp, ray.origin, ray.direction, held[j].begin(), held[j].end());
        });
        rayed.clear();
        rays.clear();
        for (std::size_t j = 0; j < n; ++j) {
            if (held[j].n > 0) {
                rayed.push_back(static_cast<std::uint32_t>(j));
                rays.push_back(all[j]);
            }
        }
        if (!engine.intersect(rays, opt, r).ok())
            return {};
        tbb::parallel_for(std::size_t(0), rayed.size(), [&](std::size_t m) {
            const std::size_t j = rayed[m];
            out[at + j] = verdict(r.hits.data() + r.offsets[m], r.hits.data() + r.offsets[m + 1],
                                  pp, held[j].begin(), held[j].end());
        });
    }
    return out;
}

/// Inside by crossing parity for the listed points: only the pieces whose boxes hold a point
/// count for it (none: outside, no ray); the first ray along the line to the nearest surface
/// point, then the retries of the file comment for rays that met an edge.
void parity_inside(const QueryEngine& engine, const Vec3d* points, NearestHits nearest,
                   const std::vector<std::size_t>& which, const CancelToken& cancel,
                   Occupancy* out) {
    if (which.empty())
        return;  // nothing to decide: the pieces are not built for nothing
    // The first ray leaves the nearest surface the short way: straight away from it where p is
    // on the side its normal points to (outside, when the mesh faces out), and straight through
    // it where p is behind it, so that the ray reaches the end of its pieces' boxes after
    // crossing one surface rather than the whole solid (B's shell: half the points are inside).
    // Which way changes no answer, only the ray's length: every crossing on any ray from p is at
    // least p's distance from the surface away, more than the rounding of a t.
    auto short_way = [&](std::size_t i) {
        const Vec3d off = points[i] - nearest[i].point;
        const Vec3d d = normalize(dot(off, nearest[i].normal) < 0.0 ? -off : off);
        return d == Vec3d{} ? kRetryDirections[0] : d;
    };
    const std::vector<RayVerdict> first = cast(engine, points, which, short_way, cancel);
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
            engine, points, again, [&](std::size_t) { return d; }, cancel);
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

Status classify_points(const QueryEngine& engine, const Vec3d* points, NearestHits nearest,
                       std::size_t n, bool all_objects, const CancelToken& cancel, Occupancy* out,
                       const std::vector<std::uint32_t>& order) {
    const Scene& s = engine.scene();
    const std::vector<MeshTopology>& topo = engine.topology();
    std::vector<std::uint32_t> spheres, windings;
    bool any_parity = false;
    for (std::uint32_t i = 0; i < s.objects.size(); ++i) {
        const Object& o = s.objects[i];
        if (o.kind == ObjectKind::sphere) {
            spheres.push_back(i);
        } else if (topo[i].sign == SignMethod::parity) {
            any_parity = true;
        } else {
            windings.push_back(i);
        }
    }
    // On a surface, then spheres: exact and cheap, point by point.
    // The winding number is the largest over the objects; with only winding meshes it may be
    // negative (a mesh facing inwards), so it starts at the lowest value an object can give.
    const double no_winding = spheres.empty() && !any_parity ? -kInfinity : 0.0;
    auto open = [&](std::size_t i) {
        return nearest[i].valid() && !on_surface(nearest[i]) && (all_objects || !out[i].inside);
    };
    // Whether each point is still open after the spheres, for the parity list below: gathered
    // here in parallel, so that the list is made from a byte a point rather than by a serial
    // pass over the scattered hits (in a spatial order every read of a hit missed cache).
    std::vector<std::uint8_t> still_open(any_parity ? n : 0);
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
        if (any_parity)
            still_open[i] = open(i);
    });
    if (any_parity && !cancel.fired()) {
        std::vector<std::size_t> which;
        for (std::size_t k = 0; k < n; ++k) {
            const std::size_t i = order.empty() ? k : order[k];
            if (still_open[i])
                which.push_back(i);
        }
        parity_inside(engine, points, nearest, which, cancel, out);
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
