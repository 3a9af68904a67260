#include "engine/mesh/edge_map.h"

#include <algorithm>
#include <numeric>

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

/// One group of half-edges on the same undirected edge lo–hi, entries [b, e).
void classify_edge(const WeldedTriangles& w, const Entry* b, const Entry* e, std::uint32_t lo,
                   EdgeMap& out) {
    ++out.edges;
    const std::size_t n = static_cast<std::size_t>(e - b);
    if (n == 1) {
        ++out.boundary_edges;
        const auto& t = w.triangles[b[0].he / 3];
        out.boundary.emplace_back(t[b[0].he % 3], t[(b[0].he % 3 + 1) % 3]);
        return;
    }
    if (n > 2) {
        ++out.non_manifold_edges;
        return;
    }
    // A half-edge runs lo → hi when its first corner is lo.
    auto runs_up = [&](std::uint32_t he) { return w.triangles[he / 3][he % 3] == lo; };
    const bool same = runs_up(b[0].he) == runs_up(b[1].he);
    out.same_direction_edges += same;
    out.neighbour[b[0].he] = b[1].he / 3;
    out.neighbour[b[1].he] = b[0].he / 3;
    out.same_direction[b[0].he] = out.same_direction[b[1].he] = same;
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
    for (std::uint32_t lo = 0; lo < w.vertices; ++lo) {
        Entry* b = entries.data() + off[lo];
        Entry* e = entries.data() + off[lo + 1];
        // An empty row does nothing; with no faces at all entries.data() is null, and b + 1 would
        // offset a null pointer (UBSan, found by fuzz_scene_doc).
        if (b == e)
            continue;
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
            classify_edge(w, g, h, lo, out);
            g = h;
        }
    }
    return out;
}

std::size_t count_non_manifold_vertices(const WeldedTriangles& w, const EdgeMap& e) {
    // The faces around each vertex (a CSR table; each row is in increasing triangle order).
    std::vector<std::uint32_t> cursor(w.vertices, 0);
    for (const auto& t : w.triangles) {
        if (is_face(t)) {
            for (std::uint32_t v : t)
                ++cursor[v];
        }
    }
    const std::vector<std::uint32_t> off = offsets_from(cursor);
    std::vector<std::uint32_t> faces(off.back());
    for (std::uint32_t t = 0; t < w.triangles.size(); ++t) {
        if (is_face(w.triangles[t])) {
            for (std::uint32_t v : w.triangles[t])
                faces[cursor[v]++] = t;
        }
    }
    std::size_t count = 0;
    std::vector<std::uint32_t> parent;
    for (std::uint32_t v = 0; v < w.vertices; ++v) {
        const std::uint32_t* row = faces.data() + off[v];
        const std::size_t n = off[v + 1] - off[v];
        if (n < 2)
            continue;
        // Fans: the faces at v joined across the two edges each has at v, where those edges
        // have exactly two faces. Local union-find over the row; a neighbour is found in the
        // sorted row by binary search (a fan of 100,000 faces stays O(n log n)).
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
        count += fans > 1;
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
