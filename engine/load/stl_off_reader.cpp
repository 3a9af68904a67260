// STL and OFF, read by hand.
//
// OpenMesh reads both, but its STL reader silently drops triangles whose corners coincide
// (Spider_binary.stl has 56 such), which would renumber every later triangle, and its OFF
// reader reads a stream using header flags left in its process-wide singleton by a previous
// call, does not skip '#' comments, and loops over a face count it never checks against the
// input. Both formats are a few lines of grammar, so we read them ourselves.

#include <algorithm>
#include <cctype>
#include <cstring>
#include <unordered_map>

#include "engine/load/loaders.h"
#include "engine/load/text_scan.h"

namespace raycastd::engine::detail {

namespace {

/// Merges exactly equal positions into one vertex. STL stores every triangle's corners
/// separately; sharing them gives the mesh the connectivity the file implies, as OpenMesh's
/// and most STL readers do (−0 and +0 are the same point).
class VertexWelder {
  public:
    explicit VertexWelder(TriangleMesh& mesh) : mesh_(mesh) {}

    std::uint32_t add(const Vec3d& p) {
        Key k{bits(p.x), bits(p.y), bits(p.z)};
        auto [it, inserted] = index_.emplace(k, static_cast<std::uint32_t>(mesh_.positions.size()));
        if (inserted)
            mesh_.positions.push_back(p);
        return it->second;
    }

  private:
    using Key = std::array<std::uint64_t, 3>;
    struct Hash {
        std::size_t operator()(const Key& k) const {
            return std::hash<std::uint64_t>()(k[0] * 0x9E3779B97F4A7C15ull ^
                                              k[1] * 0xC2B2AE3D27D4EB4Full ^ k[2]);
        }
    };
    static std::uint64_t bits(double v) {
        if (v == 0.0)
            v = 0.0;
        std::uint64_t b;
        std::memcpy(&b, &v, sizeof b);
        return b;
    }

    TriangleMesh& mesh_;
    std::unordered_map<Key, std::uint32_t, Hash> index_;
};

std::uint32_t read_u32_le(const unsigned char* p) {
    return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
           static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

float read_f32_le(const unsigned char* p) {
    const std::uint32_t u = read_u32_le(p);
    float f;
    std::memcpy(&f, &u, sizeof f);
    return f;
}

// Binary STL (3D Systems, "StereoLithography Interface Specification", 1989): 80-byte header,
// uint32 triangle count n, then n records of 50 bytes: normal (3 × float32, ignored: the
// winding defines the face), three vertices (3 × float32 each), a uint16 attribute. All
// little-endian.
void read_binary_stl(std::string_view b, std::uint32_t n, TriangleMesh& mesh) {
    VertexWelder weld(mesh);
    const auto* p = reinterpret_cast<const unsigned char*>(b.data()) + 84;
    mesh.triangles.reserve(n);
    for (std::uint32_t t = 0; t < n; ++t, p += 50) {
        std::array<std::uint32_t, 3> tri{};
        for (std::size_t c = 0; c < 3; ++c) {
            const unsigned char* v = p + 12 + 12 * c;
            tri[c] = weld.add({read_f32_le(v), read_f32_le(v + 4), read_f32_le(v + 8)});
        }
        mesh.triangles.push_back(tri);
    }
}

// ASCII STL: "solid name", then per facet "facet normal nx ny nz", "outer loop", three
// "vertex x y z", "endloop", "endfacet"; "endsolid name". Keywords in any case; several solids
// may follow each other; all their facets go into the one part.
Status read_ascii_stl(std::string_view text, std::string_view name, TriangleMesh& mesh) {
    VertexWelder weld(mesh);
    LineReader lines(text);
    std::string_view line;
    std::vector<std::uint32_t> loop;
    auto close_loop = [&]() -> Status {
        if (loop.empty())
            return {};
        if (loop.size() != 3) {
            return load_error(name, "line " + std::to_string(lines.number()) + ": a facet has " +
                                        std::to_string(loop.size()) + " vertices, STL needs 3");
        }
        mesh.triangles.push_back({loop[0], loop[1], loop[2]});
        loop.clear();
        return {};
    };
    while (lines.next(line)) {
        auto t = tokens(line, /*comments=*/false);
        if (t.empty())
            continue;
        const std::string k = lower(t[0]);
        if (k == "vertex") {
            if (t.size() < 4)
                return load_error(
                    name, "line " + std::to_string(lines.number()) + ": a vertex needs x, y and z");
            auto x = parse_double(t[1]), y = parse_double(t[2]), z = parse_double(t[3]);
            if (!x || !y || !z)
                return load_error(name,
                                  "line " + std::to_string(lines.number()) + ": malformed vertex");
            loop.push_back(weld.add({*x, *y, *z}));
        } else if (k == "endloop" || k == "endfacet" || k == "facet" || k == "endsolid") {
            if (Status st = close_loop(); !st.ok())
                return st;
        }
    }
    if (!loop.empty())
        return load_error(name, "the last facet is incomplete (truncated file?)");
    return {};
}

}  // namespace

Result<LoadedModel> load_stl(std::string_view bytes, std::string_view name,
                             const LoadLimits& limits) {
    LoadedModel model;
    ModelPart part;
    part.name = std::string(name);
    const bool has_count = bytes.size() >= 84;
    const std::uint32_t n =
        has_count ? read_u32_le(reinterpret_cast<const unsigned char*>(bytes.data()) + 80) : 0;
    const std::uint64_t binary_size = 84 + 50 * static_cast<std::uint64_t>(n);
    std::size_t text_start = 0;
    while (text_start < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[text_start])))
        ++text_start;
    const bool says_solid = lower(bytes.substr(text_start, 5)) == "solid";
    // The size rule decides first: a binary header may begin with "solid" too.
    if (has_count && binary_size == bytes.size()) {
        if (n > limits.max_triangles)
            return Status::error(Code::too_large, std::string(name) + ": " + std::to_string(n) +
                                                      " triangles exceed the limit");
        read_binary_stl(bytes, n, part.mesh);
    } else if (says_solid) {
        if (Status st = read_ascii_stl(bytes, name, part.mesh); !st.ok())
            return st;
    } else if (has_count && binary_size < bytes.size()) {
        if (n > limits.max_triangles)
            return Status::error(Code::too_large, std::string(name) + ": " + std::to_string(n) +
                                                      " triangles exceed the limit");
        read_binary_stl(bytes, n, part.mesh);
        model.warnings.push_back(std::to_string(bytes.size() - binary_size) +
                                 " bytes after the last STL triangle ignored");
    } else if (has_count) {
        return load_error(name, "truncated binary STL: the header announces " + std::to_string(n) +
                                    " triangles (" + std::to_string(binary_size) +
                                    " bytes) but the file has " + std::to_string(bytes.size()) +
                                    " bytes");
    } else {
        return load_error(name, "not an STL file: too short for binary STL and no 'solid' keyword");
    }
    model.parts.push_back(std::move(part));
    if (Status st = finish_model(model, name, limits); !st.ok())
        return st;
    return model;
}

// OFF (Geomview "OFF" format, geomview.org/docs/html/OFF.html): a header keyword
// [ST][C][N]OFF, the counts "nv nf ne", nv vertex lines "x y z [nx ny nz] [colour] [s t]", nf
// face lines "k i1 … ik [colour]". '#' starts a comment. Vertex and face records are read one
// per line because the optional colour fields make token counts ambiguous otherwise. 4OFF,
// nOFF (other dimensions) and binary OFF are not supported.
namespace {

class OffReader {
  public:
    OffReader(std::string_view bytes, std::string_view name, const LoadLimits& limits)
        : bytes_(bytes), lines_(bytes), name_(name), limits_(limits) {
        part_.name = std::string(name);
    }

    Result<LoadedModel> run() {
        if (Status st = header(); !st.ok())
            return st;
        if (Status st = vertices(); !st.ok())
            return st;
        if (Status st = faces(); !st.ok())
            return st;
        model_.parts.push_back(std::move(part_));
        if (Status st = finish_model(model_, name_, limits_); !st.ok())
            return st;
        return std::move(model_);
    }

  private:
    /// The next line with tokens (comments and blank lines skipped); false at the end.
    bool next(std::vector<std::string_view>& t) {
        std::string_view line;
        while (lines_.next(line)) {
            t = tokens(line);
            if (!t.empty())
                return true;
        }
        return false;
    }
    Status error(const std::string& what) {
        return load_error(name_, "line " + std::to_string(lines_.number()) + ": " + what);
    }
    Status unsupported(const std::string& what) {
        return Status::error(Code::unsupported_format, std::string(name_) + ": " + what);
    }

    Status header() {
        std::vector<std::string_view> t;
        if (!next(t))
            return load_error(name_, "empty OFF file");
        std::string_view head = t[0];
        if (head.substr(0, 3) == "\xEF\xBB\xBF")
            head.remove_prefix(3);
        const std::size_t off_at = head.find("OFF");
        if (off_at == std::string_view::npos)
            return error("not an OFF file (no OFF keyword)");
        const std::string_view flags = head.substr(0, off_at);
        if (flags.find_first_of("4n") != std::string_view::npos) {
            return unsupported("only 3-dimensional OFF is supported");
        }
        if (flags.find_first_not_of("STCN") != std::string_view::npos) {
            return error("unknown OFF header '" + std::string(head) + "'");
        }
        has_normals_ = flags.find('N') != std::string_view::npos;
        // The counts may follow on the header line, even glued to it ("OFF8 6 12").
        std::vector<std::string_view> counts;
        if (head.size() > off_at + 3)
            counts.push_back(head.substr(off_at + 3));
        counts.insert(counts.end(), t.begin() + 1, t.end());
        if (!counts.empty() && counts[0] == "BINARY")
            return unsupported("binary OFF is not supported");
        if (counts.empty() && !next(counts))
            return error("missing vertex and face counts");
        auto nv = counts.size() >= 2 ? parse_int(counts[0]) : std::nullopt;
        auto nf = counts.size() >= 2 ? parse_int(counts[1]) : std::nullopt;
        if (!nv || !nf || *nv < 0 || *nf < 0)
            return error("malformed vertex and face counts");
        // Every record takes at least two bytes ("0\n"), so larger counts are lies; refusing
        // them up front keeps a bogus header from reserving gigabytes.
        nv_ = static_cast<std::uint64_t>(*nv);
        nf_ = static_cast<std::uint64_t>(*nf);
        if (nv_ + nf_ > bytes_.size() / 2 + 1) {
            return error("the header announces " + std::to_string(nv_) + " vertices and " +
                         std::to_string(nf_) + " faces, more than the file can hold");
        }
        return {};
    }

    Status vertices() {
        TriangleMesh& mesh = part_.mesh;
        mesh.positions.reserve(nv_);
        const std::size_t numbers = has_normals_ ? 6 : 3;
        std::vector<std::string_view> t;
        for (std::uint64_t v = 0; v < nv_; ++v) {
            if (!next(t)) {
                return load_error(name_, "file ends after " + std::to_string(v) + " of " +
                                             std::to_string(nv_) + " vertices");
            }
            if (t.size() < numbers)
                return error("a vertex needs " + std::to_string(numbers) + " numbers");
            std::array<double, 6> x{};
            for (std::size_t i = 0; i < numbers; ++i) {
                auto d = parse_double(t[i]);
                if (!d)
                    return error("malformed number '" + std::string(t[i]) + "'");
                x[i] = *d;
            }
            mesh.positions.push_back({x[0], x[1], x[2]});
            if (has_normals_)
                mesh.normals.push_back(Vec3f(Vec3d{x[3], x[4], x[5]}));
        }
        return {};
    }

    Status faces() {
        std::vector<std::string_view> t;
        std::vector<std::uint32_t> poly;
        std::size_t short_faces = 0;
        for (std::uint64_t f = 0; f < nf_; ++f) {
            if (!next(t)) {
                return load_error(name_, "file ends after " + std::to_string(f) + " of " +
                                             std::to_string(nf_) + " faces");
            }
            auto k = parse_int(t[0]);
            if (!k || *k < 0 || static_cast<std::uint64_t>(*k) > t.size() - 1) {
                return error("face vertex count does not match the indices on its line");
            }
            poly.clear();
            for (std::size_t i = 1; i <= static_cast<std::size_t>(*k); ++i) {
                auto idx = parse_int(t[i]);
                if (!idx || *idx < 0 || static_cast<std::uint64_t>(*idx) >= nv_) {
                    return error("face index '" + std::string(t[i]) + "' is not one of the " +
                                 std::to_string(nv_) + " vertices");
                }
                poly.push_back(static_cast<std::uint32_t>(*idx));
            }
            if (add_fan(part_.mesh, poly) == 0)
                ++short_faces;
            if (part_.mesh.triangles.size() > limits_.max_triangles) {
                return Status::error(Code::too_large, std::string(name_) + ": more than " +
                                                          std::to_string(limits_.max_triangles) +
                                                          " triangles");
            }
        }
        if (short_faces > 0) {
            model_.warnings.push_back(std::to_string(short_faces) +
                                      " faces with fewer than 3 vertices skipped");
        }
        return {};
    }

    std::string_view bytes_;
    LineReader lines_;
    std::string_view name_;
    const LoadLimits& limits_;
    LoadedModel model_;
    ModelPart part_;
    bool has_normals_ = false;
    std::uint64_t nv_ = 0, nf_ = 0;
};

}  // namespace

Result<LoadedModel> load_off(std::string_view bytes, std::string_view name,
                             const LoadLimits& limits) {
    return OffReader(bytes, name, limits).run();
}

}  // namespace raycastd::engine::detail
