#include "bench/workloads.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <unordered_map>

namespace raycastd::bench {

namespace {

/// SplitMix64 (Steele, Lea & Flood, OOPSLA 2014): tiny, and its sequence is the same with every
/// standard library, unlike std::uniform_real_distribution.
class Rng {
  public:
    explicit Rng(std::uint64_t seed) : state_(seed) {}
    /// Uniform in [0, 1), 53 random bits.
    double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
    double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

  private:
    std::uint64_t next() {
        std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    std::uint64_t state_;
};

using Vec3 = std::array<double, 3>;

Vec3 normalized(const Vec3& v) {
    const double len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return {v[0] / len, v[1] / len, v[2] / len};
}

/// Unit icosphere in double precision (rounded to float once, by the callers).
struct Icosphere {
    std::vector<Vec3> positions;
    std::vector<std::array<std::uint32_t, 3>> triangles;
};

/// The regular icosahedron: vertices are the cyclic permutations of (0, ±1, ±φ).
Icosphere icosahedron() {
    const double p = (1.0 + std::sqrt(5.0)) / 2.0;
    Icosphere ico;
    const Vec3 v[12] = {{-1, p, 0},  {1, p, 0},  {-1, -p, 0}, {1, -p, 0}, {0, -1, p},  {0, 1, p},
                        {0, -1, -p}, {0, 1, -p}, {p, 0, -1},  {p, 0, 1},  {-p, 0, -1}, {-p, 0, 1}};
    for (const Vec3& x : v)
        ico.positions.push_back(normalized(x));
    ico.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                     {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                     {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                     {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    // Make every face counter-clockwise seen from outside: (b−a)×(c−a) points away from the
    // centre, i.e. along the face centroid.
    for (auto& t : ico.triangles) {
        const Vec3& a = ico.positions[t[0]];
        const Vec3& b = ico.positions[t[1]];
        const Vec3& c = ico.positions[t[2]];
        const Vec3 e1{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const Vec3 e2{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        const Vec3 n{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                     e1[0] * e2[1] - e1[1] * e2[0]};
        if (n[0] * (a[0] + b[0] + c[0]) + n[1] * (a[1] + b[1] + c[1]) +
                n[2] * (a[2] + b[2] + c[2]) <
            0.0) {
            std::swap(t[1], t[2]);
        }
    }
    return ico;
}

/// One 1-to-4 subdivision; edge midpoints are shared between the two faces of an edge, so the
/// mesh stays closed.
void subdivide(Icosphere& ico) {
    std::unordered_map<std::uint64_t, std::uint32_t> midpoint;
    auto mid = [&](std::uint32_t a, std::uint32_t b) {
        const std::uint64_t key = (std::uint64_t{std::min(a, b)} << 32) | std::max(a, b);
        auto it = midpoint.find(key);
        if (it != midpoint.end())
            return it->second;
        const Vec3& p = ico.positions[a];
        const Vec3& q = ico.positions[b];
        ico.positions.push_back(normalized({p[0] + q[0], p[1] + q[1], p[2] + q[2]}));
        const auto index = static_cast<std::uint32_t>(ico.positions.size() - 1);
        midpoint.emplace(key, index);
        return index;
    };
    std::vector<std::array<std::uint32_t, 3>> out;
    out.reserve(ico.triangles.size() * 4);
    for (const auto& t : ico.triangles) {
        const std::uint32_t ab = mid(t[0], t[1]);
        const std::uint32_t bc = mid(t[1], t[2]);
        const std::uint32_t ca = mid(t[2], t[0]);
        out.push_back({t[0], ab, ca});
        out.push_back({t[1], bc, ab});
        out.push_back({t[2], ca, bc});
        out.push_back({ab, bc, ca});
    }
    ico.triangles = std::move(out);
}

Icosphere unit_icosphere(int level) {
    Icosphere ico = icosahedron();
    for (int i = 0; i < level; ++i)
        subdivide(ico);
    return ico;
}

std::string with_thousands(std::size_t n) {
    std::string digits = std::to_string(n);
    std::string out;
    for (std::size_t i = 0; i < digits.size(); ++i) {
        if (i > 0 && (digits.size() - i) % 3 == 0)
            out += ',';
        out += digits[i];
    }
    return out;
}

}  // namespace

std::array<float, 6> Workload::bounds() const {
    std::array<float, 6> b{INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (const auto& p : positions) {
        for (int k = 0; k < 3; ++k) {
            b[k] = std::min(b[k], p[k]);
            b[k + 3] = std::max(b[k + 3], p[k]);
        }
    }
    for (const auto& s : spheres) {
        for (int k = 0; k < 3; ++k) {
            b[k] = std::min(b[k], s[k] - s[3]);
            b[k + 3] = std::max(b[k + 3], s[k] + s[3]);
        }
    }
    return b;
}

std::array<float, 4> Workload::bounding_sphere() const {
    const auto b = bounds();
    const double c[3] = {0.5 * (double{b[0]} + b[3]), 0.5 * (double{b[1]} + b[4]),
                         0.5 * (double{b[2]} + b[5])};
    auto dist = [&](float x, float y, float z) {
        return std::sqrt((x - c[0]) * (x - c[0]) + (y - c[1]) * (y - c[1]) +
                         (z - c[2]) * (z - c[2]));
    };
    double r = 0.0;
    for (const auto& p : positions)
        r = std::max(r, dist(p[0], p[1], p[2]));
    for (const auto& s : spheres)
        r = std::max(r, dist(s[0], s[1], s[2]) + s[3]);
    return {static_cast<float>(c[0]), static_cast<float>(c[1]), static_cast<float>(c[2]),
            static_cast<float>(r)};
}

Workload make_icosphere(int level) {
    const Icosphere ico = unit_icosphere(level);
    Workload w;
    w.name = "A";
    w.description = "icosphere, " + with_thousands(ico.triangles.size()) + " triangles";
    for (const Vec3& p : ico.positions) {
        w.positions.push_back(
            {static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2])});
    }
    w.triangles = ico.triangles;
    return w;
}

Workload make_icosphere_field(int count, int level, std::uint64_t seed) {
    const Icosphere ico = unit_icosphere(level);
    Rng rng(seed);
    // Centres in a cube whose side grows with the cube root of the count, so the spheres fill
    // it like a cluttered scene (some overlap, most do not).
    const double side = 3.0 * std::cbrt(static_cast<double>(count));
    Workload w;
    w.name = "B";
    w.positions.reserve(ico.positions.size() * static_cast<std::size_t>(count));
    w.triangles.reserve(ico.triangles.size() * static_cast<std::size_t>(count));
    for (int i = 0; i < count; ++i) {
        const Vec3 c{rng.uniform(0, side), rng.uniform(0, side), rng.uniform(0, side)};
        const double r = rng.uniform(0.5, 1.5);
        const auto base = static_cast<std::uint32_t>(w.positions.size());
        for (const Vec3& p : ico.positions) {
            w.positions.push_back({static_cast<float>(c[0] + r * p[0]),
                                   static_cast<float>(c[1] + r * p[1]),
                                   static_cast<float>(c[2] + r * p[2])});
        }
        for (const auto& t : ico.triangles) {
            w.triangles.push_back({base + t[0], base + t[1], base + t[2]});
        }
    }
    w.description = std::to_string(count) + " icospheres merged, " +
                    with_thousands(w.triangles.size()) + " triangles";
    return w;
}

Workload make_sphere_field(int count, std::uint64_t seed) {
    Rng rng(seed);
    const double side = 2.0 * std::cbrt(static_cast<double>(count));
    Workload w;
    w.name = "C";
    w.description = with_thousands(static_cast<std::size_t>(count)) + " analytic spheres";
    for (int i = 0; i < count; ++i) {
        w.spheres.push_back(
            {static_cast<float>(rng.uniform(0, side)), static_cast<float>(rng.uniform(0, side)),
             static_cast<float>(rng.uniform(0, side)), static_cast<float>(rng.uniform(0.3, 1.0))});
    }
    return w;
}

std::vector<RayRecord> camera_rays(const Workload& w, int width, int height) {
    const auto s = w.bounding_sphere();
    // The bounding sphere subtends the vertical field of view exactly: distance = r / sin(fov/2).
    constexpr double kHalfFov = 22.5 * 3.14159265358979323846 / 180.0;
    const double tan_half = std::tan(kHalfFov);
    const double distance = s[3] / std::sin(kHalfFov);
    const Vec3 eye{s[0], s[1], s[2] - distance};
    const double aspect = static_cast<double>(width) / height;
    std::vector<RayRecord> rays;
    rays.reserve(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
    for (int ty = 0; ty < height; ty += 4) {
        for (int tx = 0; tx < width; tx += 4) {
            for (int y = ty; y < ty + 4; ++y) {
                for (int x = tx; x < tx + 4; ++x) {
                    // Pixel centres; image y grows downwards, camera up is +y.
                    const double sx = (2.0 * (x + 0.5) / width - 1.0) * tan_half * aspect;
                    const double sy = (1.0 - 2.0 * (y + 0.5) / height) * tan_half;
                    const Vec3 d = normalized({sx, sy, 1.0});
                    rays.push_back({static_cast<float>(eye[0]), static_cast<float>(eye[1]),
                                    static_cast<float>(eye[2]), static_cast<float>(d[0]),
                                    static_cast<float>(d[1]), static_cast<float>(d[2]), 0.0f,
                                    kRayTmax});
                }
            }
        }
    }
    return rays;
}

std::vector<RayRecord> random_rays(const Workload& w, std::size_t n, std::uint64_t seed) {
    const auto b = w.bounds();
    Rng rng(seed);
    double lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
        const double c = 0.5 * (double{b[k]} + b[k + 3]);
        const double half = 0.75 * (double{b[k + 3]} - b[k]);
        lo[k] = c - half;
        hi[k] = c + half;
    }
    std::vector<RayRecord> rays;
    rays.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double ox = rng.uniform(lo[0], hi[0]);
        const double oy = rng.uniform(lo[1], hi[1]);
        const double oz = rng.uniform(lo[2], hi[2]);
        // Uniform on the sphere (Archimedes): z uniform in [−1, 1], azimuth uniform.
        const double z = rng.uniform(-1.0, 1.0);
        const double phi = rng.uniform(0.0, 2.0 * 3.14159265358979323846);
        const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
        rays.push_back({static_cast<float>(ox), static_cast<float>(oy), static_cast<float>(oz),
                        static_cast<float>(r * std::cos(phi)),
                        static_cast<float>(r * std::sin(phi)), static_cast<float>(z), 0.0f,
                        kRayTmax});
    }
    return rays;
}

Workload make_workload(char name, const WorkloadSizes& s) {
    switch (name) {
        case 'A':
            return make_icosphere(s.ico_level);
        case 'B':
            return make_icosphere_field(s.field_count, s.field_level, kFieldSeed);
        default:
            return make_sphere_field(s.spheres, kSphereSeed);
    }
}

std::vector<RayRecord> ray_set(const Workload& w, bool coherent, const WorkloadSizes& s) {
    return coherent ? camera_rays(w, s.image, s.image) : random_rays(w, s.random_rays, kRaySeed);
}

engine::Scene to_engine_scene(const Workload& w) {
    engine::Scene scene;
    scene.materials.push_back(engine::Material{});
    scene.material_names.push_back("default");
    if (!w.triangles.empty()) {
        auto mesh = std::make_shared<engine::TriangleMesh>();
        mesh->positions.reserve(w.positions.size());
        for (const auto& p : w.positions)
            mesh->positions.push_back({p[0], p[1], p[2]});
        mesh->triangles = w.triangles;
        engine::Object o;
        o.kind = engine::ObjectKind::mesh;
        o.name = w.name;
        o.mesh = std::move(mesh);
        scene.objects.push_back(std::move(o));
    }
    for (std::size_t i = 0; i < w.spheres.size(); ++i) {
        const auto& s = w.spheres[i];
        engine::Object o;
        o.kind = engine::ObjectKind::sphere;
        o.name = "sphere " + std::to_string(i + 1);
        o.sphere = {{s[0], s[1], s[2]}, s[3]};
        scene.objects.push_back(std::move(o));
    }
    return scene;
}

std::vector<engine::Ray> to_engine_rays(const std::vector<RayRecord>& rays) {
    std::vector<engine::Ray> out;
    out.reserve(rays.size());
    for (const RayRecord& r : rays) {
        out.push_back({{r.ox, r.oy, r.oz}, {r.dx, r.dy, r.dz}, r.tmin, r.tmax});
    }
    return out;
}

}  // namespace raycastd::bench
