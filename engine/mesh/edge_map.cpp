#include "engine/mesh/edge_map.h"

#include <algorithm>
#include <iterator>
#include <numeric>

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

namespace raycastd::engine {

namespace {

/// One half-edge in the CSR table of its lower vertex: the upper vertex and the half-edge's id
/// (3t + k: triangle t, corners k → k+1).
struct Entry {
    std::uint32_t hi;
    std::uint32_t he;
};

/// Disjoint sets with path halving and union by index (the lower root wins, which keeps the
/// result independent of the order of the unions).
class UnionFind {
  public:
    explicit UnionFind(std::size_t n) : parent_(n) {
        std::iota(parent_.begin(), parent_.end(), 0u);
    }
    std::uint32_t find(std::uint32_t x) {
        while (parent_[x] != x) {
            parent_[x] = parent_[parent_[x]];
            x = parent_[x];
        }
        return x;
    }
    void join(std::uint32_t a, std::uint32_t b) {
        a = find(a);
        b = find(b);
        if (a != b)
            parent_[std::max(a, b)] = std::min(a, b);
    }
    /// The number of sets among elements 0 .. n−1.
    std::size_t roots() {
        std::size_t n = 0;
        for (std::uint32_t i = 0; i < parent_.size(); ++i)
            n += find(i) == i;
        return n;
    }

  private:
    std::vector<std::uint32_t> parent_;
};

/// Offsets of a CSR table from per-row counts (counts becomes the fill cursor).
std::vector<std::uint32_t> offsets_from(std::vector<std::uint32_t>& counts) {
    std::vector<std::uint32_t> off(counts.size() + 1, 0);
    for (std::size_t v = 0; v < counts.size(); ++v)
        off[v + 1] = off[v] + counts[v];
    std::copy(off.begin(), off.end() - 1, counts.begin());
    return off;
}

/// The counts and boundary edges of a range of the edge map's rows; partial results of the
/// parallel pass, joined in row order (so that `boundary` is the same as a serial pass's).
struct EdgeCounts {
    std::size_t edges = 0, boundary_edges = 0, non_manifold_edges = 0, same_direction_edges = 0;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> boundary;

    void join(EdgeCounts& right) {
        edges += right.edges;
        boundary_edges += right.boundary_edges;
        non_manifold_edges += right.non_manifold_edges;
        same_direction_edges += right.same_direction_edges;
        boundary.insert(boundary.end(), std::make_move_iterator(right.boundary.begin()),
                        std::make_move_iterator(right.boundary.end()));
    }
};

/// One group of half-edges on the same undirected edge lo–hi, entries [b, e). Writes the
/// neighbours of those half-edges only (no other group's), so rows can be classified in parallel.
void classify_edge(const WeldedTriangles& w, const Entry* b, const Entry* e, std::uint32_t lo,
                   EdgeCounts& counts, EdgeMap& out) {
    ++counts.edges;
    const std::size_t n = static_cast<std::size_t>(e - b);
    if (n == 1) {
        ++counts.boundary_edges;
        const auto& t = w.triangles[b[0].he / 3];
        counts.boundary.emplace_back(t[b[0].he % 3], t[(b[0].he % 3 + 1) % 3]);
        return;
    }
    if (n > 2) {
        ++counts.non_manifold_edges;
        return;
    }
    // A half-edge runs lo → hi when its first corner is lo.
    auto runs_up = [&](std::uint32_t he) { return w.triangles[he / 3][he % 3] == lo; };
    const bool same = runs_up(b[0].he) == runs_up(b[1].he);
    counts.same_direction_edges += same;
    out.neighbour[b[0].he] = b[1].he / 3;
    out.neighbour[b[1].he] = b[0].he / 3;
    out.same_direction[b[0].he] = out.same_direction[b[1].he] = same;
}

/// Sorts the half-edges of row lo (by upper vertex, stably) and classifies each edge in it.
void classify_row(const WeldedTriangles& w, Entry* b, Entry* e, std::uint32_t lo,
                  EdgeCounts& counts, EdgeMap& out) {
    // Stable: the half-edges of one edge stay in triangle order. Rows are short (about six
    // entries): insertion sort, without the buffer std::stable_sort allocates per call (that
    // allocation was most of this pass on 1M triangles).
    if (e - b <= 32) {
        for (Entry* i = b + 1; i < e; ++i) {
            const Entry x = *i;
            Entry* j = i;
            for (; j > b && (j - 1)->hi > x.hi; --j)
                *j = *(j - 1);
            *j = x;
        }
    } else {
        std::stable_sort(b, e, [](const Entry& x, const Entry& y) { return x.hi < y.hi; });
    }
    for (Entry* g = b; g != e;) {
        Entry* h = g;
        while (h != e && h->hi == g->hi)
            ++h;
        classify_edge(w, g, h, lo, counts, out);
        g = h;
    }
}

}  // namespace

EdgeMap build_edge_map(const WeldedTriangles& w) {
    EdgeMap out;
    const std::size_t nt = w.triangles.size();
    out.neighbour.assign(3 * nt, kNoFace);
    out.same_direction.assign(3 * nt, 0);
    std::vector<std::uint32_t> cursor(w.vertices, 0);
    for (const auto& t : w.triangles) {
        if (!is_face(t))
            continue;
        ++out.faces;
        for (int k = 0; k < 3; ++k)
            ++cursor[std::min(t[k], t[(k + 1) % 3])];
    }
    const std::vector<std::uint32_t> off = offsets_from(cursor);
    std::vector<Entry> entries(off.back());
    for (std::uint32_t t = 0; t < nt; ++t) {
        const auto& tri = w.triangles[t];
        if (!is_face(tri))
            continue;
        for (std::uint32_t k = 0; k < 3; ++k) {
            const std::uint32_t a = tri[k], b = tri[(k + 1) % 3];
            entries[cursor[std::min(a, b)]++] = Entry{std::max(a, b), 3 * t + k};
        }
    }
    // The rows over the threads (a third of the topology's time on 1M triangles, serial): each
    // row writes only its own half-edges' neighbours. A body of its own rather than the lambda
    // form, which copies the partial counts (and their boundary edges) at every range.
    struct Rows {
        const WeldedTriangles& w;
        const std::vector<std::uint32_t>& off;
        std::vector<Entry>& entries;
        EdgeMap& out;
        EdgeCounts counts;

        Rows(const WeldedTriangles& w_, const std::vector<std::uint32_t>& off_,
             std::vector<Entry>& entries_, EdgeMap& out_)
            : w(w_), off(off_), entries(entries_), out(out_) {}
        Rows(Rows& o, tbb::split) : w(o.w), off(o.off), entries(o.entries), out(o.out) {}
        void operator()(const tbb::blocked_range<std::uint32_t>& r) {
            for (std::uint32_t lo = r.begin(); lo < r.end(); ++lo) {
                // An empty row does nothing; with no faces at all entries.data() is null, and
                // b + 1 would offset a null pointer (UBSan, found by fuzz_scene_doc).
                if (off[lo] != off[lo + 1])
                    classify_row(w, entries.data() + off[lo], entries.data() + off[lo + 1], lo,
                                 counts, out);
            }
        }
        void join(Rows& right) { counts.join(right.counts); }
    } rows(w, off, entries, out);
    tbb::parallel_reduce(
        tbb::blocked_range<std::uint32_t>(0, static_cast<std::uint32_t>(w.vertices), 8192), rows);
    const EdgeCounts& counts = rows.counts;
    out.edges = counts.edges;
    out.boundary_edges = counts.boundary_edges;
    out.non_manifold_edges = counts.non_manifold_edges;
    out.same_direction_edges = counts.same_direction_edges;
    out.boundary = std::move(rows.counts.boundary);
    return out;
}

namespace {

/// How a vertex's fan walk ended (count_non_manifold_vertices).
enum class Fan : std::uint8_t { single, several, unsure };

/// Walks the faces at v from face t0 across the edges at v (each of exactly two faces), taking
/// each time the edge it did not come over. Those faces and edges form a graph in which every
/// face has degree 2 while no edge at v is a boundary or non-manifold one, so the walk runs
/// around one cycle: back at t0 after all n faces at v, they form a single fan; back sooner,
/// the faces of the cycle are a fan of their own and the rest at least one more. An edge at v that
/// has not exactly two faces ends the walk undecided.
Fan walk_fan(const WeldedTriangles& w, const EdgeMap& e, std::uint32_t v, std::uint32_t t0,
             std::uint32_t n) {
    std::uint32_t prev = kNoFace, t = t0;
    for (std::uint32_t steps = 1; steps <= n; ++steps) {
        const auto& tri = w.triangles[t];
        const std::uint32_t k = tri[0] == v ? 0 : (tri[1] == v ? 1 : 2);
        const std::uint32_t out = e.neighbour[3 * t + k], in = e.neighbour[3 * t + (k + 2) % 3];
        if (out == kNoFace || in == kNoFace)
            return Fan::unsure;
        // Both edges lead to prev when the two faces share both edges at v (a cycle of two).
        const std::uint32_t next = out != prev ? out : in;
        prev = t;
        t = next;
        if (t == t0)
            return steps == n ? Fan::single : Fan::several;
    }
    return Fan::unsure;  // not back within n steps: not a graph of degree 2 after all
}

/// Whether the n faces `row` at v (increasing) fall into more than one fan: the faces joined
/// across the two edges each has at v, where those edges have exactly two faces. Local
/// union-find over the row; a neighbour is found in the sorted row by binary search (a fan of
/// 100,000 faces stays O(n log n)).
bool several_fans(const WeldedTriangles& w, const EdgeMap& e, std::uint32_t v,
                  const std::uint32_t* row, std::uint32_t n, std::vector<std::uint32_t>& parent) {
    parent.resize(n);
    std::iota(parent.begin(), parent.end(), 0u);
    auto find = [&](std::uint32_t x) {
        while (parent[x] != x)
            x = parent[x] = parent[parent[x]];
        return x;
    };
    for (std::uint32_t i = 0; i < n; ++i) {
        const std::uint32_t t = row[i];
        const auto& tri = w.triangles[t];
        const std::uint32_t k = tri[0] == v ? 0 : (tri[1] == v ? 1 : 2);
        for (std::uint32_t he : {3 * t + k, 3 * t + (k + 2) % 3}) {  // out of v, into v
            const std::uint32_t g = e.neighbour[he];
            if (g == kNoFace)
                continue;
            const auto j = static_cast<std::uint32_t>(std::lower_bound(row, row + n, g) - row);
            const std::uint32_t a = find(i), b = find(j);
            if (a != b)
                parent[std::max(a, b)] = std::min(a, b);
        }
    }
    std::size_t fans = 0;
    for (std::uint32_t i = 0; i < n && fans < 2; ++i)
        fans += find(i) == i;
    return fans > 1;
}

}  // namespace

std::size_t count_non_manifold_vertices(const WeldedTriangles& w, const EdgeMap& e) {
    // Each vertex's number of faces and one of them.
    std::vector<std::uint32_t> valence(w.vertices, 0), some(w.vertices, kNoFace);
    for (std::uint32_t t = 0; t < w.triangles.size(); ++t) {
        if (is_face(w.triangles[t])) {
            for (std::uint32_t v : w.triangles[t]) {
                ++valence[v];
                some[v] = t;
            }
        }
    }
    // Most vertices are decided by walking around them (walk_fan), over the threads: on a closed
    // mesh every one is. Only where the walk meets a boundary or non-manifold edge are the
    // vertex's faces gathered and grouped (several_fans); the union-find over every vertex was
    // the topology's largest part on 1M triangles.
    std::vector<std::uint8_t> unsure(w.vertices, 0);
    std::size_t count = tbb::parallel_reduce(
        tbb::blocked_range<std::uint32_t>(0, static_cast<std::uint32_t>(w.vertices), 16384),
        std::size_t{0},
        [&](const tbb::blocked_range<std::uint32_t>& r, std::size_t c) {
            for (std::uint32_t v = r.begin(); v < r.end(); ++v) {
                if (valence[v] < 2)
                    continue;
                switch (walk_fan(w, e, v, some[v], valence[v])) {
                    case Fan::single:
                        break;
                    case Fan::several:
                        ++c;
                        break;
                    case Fan::unsure:
                        unsure[v] = 1;
                        break;
                }
            }
            return c;
        },
        [](std::size_t a, std::size_t b) { return a + b; });
    if (std::find(unsure.begin(), unsure.end(), 1) == unsure.end())
        return count;
    // The faces around each undecided vertex (a CSR table; each row in increasing triangle
    // order).
    std::vector<std::uint32_t> cursor(w.vertices, 0);
    for (std::uint32_t v = 0; v < w.vertices; ++v)
        cursor[v] = unsure[v] ? valence[v] : 0;
    const std::vector<std::uint32_t> off = offsets_from(cursor);
    std::vector<std::uint32_t> faces(off.back());
    for (std::uint32_t t = 0; t < w.triangles.size(); ++t) {
        if (is_face(w.triangles[t])) {
            for (std::uint32_t v : w.triangles[t]) {
                if (unsure[v])
                    faces[cursor[v]++] = t;
            }
        }
    }
    std::vector<std::uint32_t> parent;
    for (std::uint32_t v = 0; v < w.vertices; ++v) {
        if (unsure[v])
            count += several_fans(w, e, v, faces.data() + off[v], off[v + 1] - off[v], parent);
    }
    return count;
}

namespace {

/// The vertices joined by the triangles that use them: count_components' and
/// label_components' sets.
UnionFind vertex_sets(const WeldedTriangles& w) {
    UnionFind sets(w.vertices);
    for (const auto& t : w.triangles) {
        sets.join(t[0], t[1]);
        sets.join(t[1], t[2]);
    }
    return sets;
}

}  // namespace

std::size_t count_components(const WeldedTriangles& w) {
    return vertex_sets(w).roots();
}

std::vector<std::uint32_t> label_components(const WeldedTriangles& w, std::uint32_t* count) {
    UnionFind sets = vertex_sets(w);
    // A root's label, given when its first triangle comes.
    std::vector<std::uint32_t> label_of_root(w.vertices, kNoFace);
    std::vector<std::uint32_t> out(w.triangles.size());
    std::uint32_t n = 0;
    for (std::size_t t = 0; t < w.triangles.size(); ++t) {
        std::uint32_t& l = label_of_root[sets.find(w.triangles[t][0])];
        if (l == kNoFace)
            l = n++;
        out[t] = l;
    }
    *count = n;
    return out;
}

std::size_t count_boundary_components(const WeldedTriangles& w, const EdgeMap& e) {
    UnionFind sets(w.vertices);
    std::vector<std::uint8_t> on(w.vertices, 0);
    for (const auto& [a, b] : e.boundary) {
        sets.join(a, b);
        on[a] = on[b] = 1;
    }
    std::size_t n = 0;
    for (std::uint32_t v = 0; v < w.vertices; ++v)
        n += on[v] && sets.find(v) == v;
    return n;
}

std::optional<std::size_t> count_boundary_loops(const WeldedTriangles& w, const EdgeMap& e) {
    std::vector<std::uint32_t> next(w.vertices, kNoFace);
    for (const auto& [from, to] : e.boundary) {
        if (next[from] != kNoFace)
            return std::nullopt;
        next[from] = to;
    }
    std::size_t loops = 0;
    for (const auto& [from, to] : e.boundary) {
        if (next[from] == kNoFace)
            continue;  // on a loop already walked
        ++loops;
        for (std::uint32_t v = from; next[v] != kNoFace;) {
            const std::uint32_t n = next[v];
            next[v] = kNoFace;
            v = n;
        }
    }
    return loops;
}

std::uint64_t valence_cost(const WeldedTriangles& w) {
    std::vector<std::uint32_t> valence(w.vertices, 0);
    for (const auto& t : w.triangles) {
        if (is_face(t)) {
            for (std::uint32_t v : t)
                ++valence[v];
        }
    }
    std::uint64_t cost = 0;
    for (std::uint32_t n : valence)
        cost += std::uint64_t(n) * n;
    return cost;
}

std::vector<std::uint8_t> orientation_flips(const WeldedTriangles& w, const EdgeMap& e) {
    const std::size_t nt = w.triangles.size();
    std::vector<std::uint8_t> flip(nt, 0), seen(nt, 0);
    std::vector<std::uint32_t> queue;
    for (std::uint32_t seed = 0; seed < nt; ++seed) {
        if (seen[seed] || !is_face(w.triangles[seed]))
            continue;
        seen[seed] = 1;
        queue.assign(1, seed);
        for (std::size_t q = 0; q < queue.size(); ++q) {
            const std::uint32_t t = queue[q];
            for (std::uint32_t k = 0; k < 3; ++k) {
                const std::uint32_t g = e.neighbour[3 * t + k];
                if (g == kNoFace || seen[g])
                    continue;
                seen[g] = 1;
                // Running the edge the same way as t means one of them is reversed.
                flip[g] = static_cast<std::uint8_t>(flip[t] ^ e.same_direction[3 * t + k]);
                queue.push_back(g);
            }
        }
    }
    return flip;
}

}  // namespace raycastd::engine
