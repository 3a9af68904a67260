// exact's BVH on its own (exact_bvh.h): the walk offers every primitive whose box the ray meets,
// and only those; a closest walk culls nothing before the tfar its visitor lowered; the AVX and
// SSE box tests agree bit for bit; degenerate trees (one primitive, none, a hundred identical
// boxes) are walked. That exact answers as the linear scan does, through this tree, is
// embree_accel_test.cpp's (EmbreeAccel.*AgreesWithLinearScan*) and the stress suites'.

#include "engine/accel/embree/exact_bvh.h"

#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "engine/accel/embree/float_ray.h"
#include "engine/accel/embree/impl.h"
#include "engine/geometry/target_clones.h"
#include "engine/testing/bits.h"
#include "engine/testing/scenes.h"

namespace raycastd::engine::embree {
namespace {

using Prim = std::pair<std::uint32_t, std::uint32_t>;  // object, primitive

/// The accelerator's frame for `scene`, as EmbreeAccel::build sets it up.
void set_frame(Impl& a, const Scene& scene) {
    a.scene = &scene;
    a.set_frame(scene.bounds());
}

/// The entry of the segment [t0, t1] of the line o + t·d into `box` grown by `grow` on every
/// side (in double: exact enough beside the margins the tests leave), or +inf if it misses.
double entry(const FloatBox& box, double grow, const double o[3], const double d[3], double t0,
             double t1) {
    for (int k = 0; k < 3; ++k) {
        const double lo = box.lo[k] - grow, hi = box.hi[k] + grow;
        if (d[k] == 0.0) {
            if (o[k] < lo || o[k] > hi)
                return std::numeric_limits<double>::infinity();
            continue;
        }
        double a = (lo - o[k]) / d[k], b = (hi - o[k]) / d[k];
        if (a > b)
            std::swap(a, b);
        t0 = std::max(t0, a);
        t1 = std::min(t1, b);
    }
    return t0 <= t1 ? t0 : std::numeric_limits<double>::infinity();
}

/// Spheres, single triangles and an icosphere of 5,120 triangles (a tree many levels deep),
/// with an empty mesh among them, so that the leaves' object numbers are checked across an
/// object without primitives.
Scene mixed_scene(std::uint64_t seed) {
    Scene s = testing::random_scene(seed);
    s.objects.insert(s.objects.begin() + static_cast<std::ptrdiff_t>(s.objects.size() / 2),
                     testing::mesh_object("empty", {}, {}));
    s.objects.push_back(testing::icosphere_object(4, {1.0, -0.5, 0.5}, 3.0));
    return s;
}

/// A float ray in a's frame from around the scene towards a point inside its bounds, some of its
/// direction's components exactly zero (the walk's ±1e-18), its range [0, ∞) or shorter.
FloatRay random_ray(const Impl& a, std::mt19937_64& rng) {
    const Bounds3 b = a.scene->bounds();
    const Vec3d lo = a.frame(b.lo), hi = a.frame(b.hi);
    std::uniform_real_distribution<double> u(0.0, 1.0), around(-1.0, 1.0);
    const Vec3d target{lo.x + u(rng) * (hi.x - lo.x), lo.y + u(rng) * (hi.y - lo.y),
                       lo.z + u(rng) * (hi.z - lo.z)};
    const Vec3d origin{around(rng), around(rng), around(rng)};
    Vec3d d = target - origin;
    if (rng() % 8 == 0)
        d.x = 0.0;
    if (rng() % 8 == 0)
        d.y = 0.0;
    FloatRay f;
    f.org_x = static_cast<float>(origin.x);
    f.org_y = static_cast<float>(origin.y);
    f.org_z = static_cast<float>(origin.z);
    f.dir_x = static_cast<float>(d.x);
    f.dir_y = static_cast<float>(d.y);
    f.dir_z = static_cast<float>(d.z);
    f.tnear = 0.0f;
    f.tfar = rng() % 2 ? std::numeric_limits<float>::infinity() : static_cast<float>(u(rng) * 1.5);
    return f;
}

/// A closest walk's visitor as the cull tests make it: tfar lowered to the entry of primitive
/// `prim` of `object`'s box plus a little, as a hit there would.
void lower_to_entry(const Impl& a, const FloatRay& f, std::uint32_t object, std::uint32_t prim,
                    float& t) {
    const double o[3] = {f.org_x, f.org_y, f.org_z}, d[3] = {f.dir_x, f.dir_y, f.dir_z};
    const double e = entry(primitive_box(a, a.scene->objects[object], prim), 0.0, o, d, f.tnear, t);
    if (e < 1e300)
        t = std::min(t, static_cast<float>(e + 0.05));
}

/// Every primitive whose box `f` meets well before the walk's final `tfar` was offered (`seen`).
void expect_none_culled(const Impl& a, const FloatRay& f, float tfar, const std::set<Prim>& seen,
                        const std::string& what) {
    const double o[3] = {f.org_x, f.org_y, f.org_z}, d[3] = {f.dir_x, f.dir_y, f.dir_z};
    const Scene& scene = *a.scene;
    for (std::uint32_t i = 0; i < scene.objects.size(); ++i)
        for (std::uint32_t p = 0; p < scene.objects[i].primitive_count(); ++p) {
            const FloatBox box = primitive_box(a, scene.objects[i], p);
            if (entry(box, -1e-5, o, d, f.tnear, static_cast<double>(tfar) - 1e-5) < 1e300) {
                EXPECT_TRUE(seen.count({i, p}))
                    << what << ": object " << i << " primitive " << p << " culled";
            }
        }
}

TEST(ExactBvh, OffersEveryPrimitiveWhoseBoxTheRayMeetsAndNoOther) {
    for (std::uint64_t seed = 1; seed <= 4; ++seed) {
        const Scene scene = mixed_scene(seed);
        Impl a;
        set_frame(a, scene);
        ExactBvh bvh;
        ASSERT_TRUE(bvh.build(a).ok());
        std::vector<std::pair<Prim, FloatBox>> boxes;
        for (std::uint32_t i = 0; i < scene.objects.size(); ++i)
            for (std::uint32_t p = 0; p < scene.objects[i].primitive_count(); ++p)
                boxes.push_back({{i, p}, primitive_box(a, scene.objects[i], p)});
        std::mt19937_64 rng(seed);
        int offered = 0;
        for (int n = 0; n < 1000; ++n) {
            const FloatRay f = random_ray(a, rng);
            std::set<Prim> seen;
            bvh.any(f, [&](std::uint32_t object, std::uint32_t prim, float&) {
                EXPECT_TRUE(seen.insert({object, prim}).second) << "offered twice";
                return true;
            });
            offered += static_cast<int>(seen.size());
            const double o[3] = {f.org_x, f.org_y, f.org_z}, d[3] = {f.dir_x, f.dir_y, f.dir_z};
            for (const auto& [prim, box] : boxes) {
                // Met with room to spare (the box shrunk by 1e-5 of the unit frame): offered;
                // missed with room to spare: not. The room on that side is a step of the
                // quantized nodes at the bottom (1/255 of a node's box, which holds primitives
                // from all over this small scene): 0.01.
                const bool met = entry(box, -1e-5, o, d, f.tnear, f.tfar) < 1e300;
                const bool near = entry(box, 0.01, o, d, f.tnear, f.tfar) < 1e300;
                if (met) {
                    EXPECT_TRUE(seen.count(prim))
                        << "seed " << seed << " ray " << n << ": object " << prim.first
                        << " primitive " << prim.second << " not offered";
                }
                if (!near) {
                    EXPECT_FALSE(seen.count(prim))
                        << "seed " << seed << " ray " << n << ": object " << prim.first
                        << " primitive " << prim.second << " offered";
                }
            }
        }
        EXPECT_GT(offered, 500) << "the rays should meet boxes";
    }
}

TEST(ExactBvh, ClosestWalkCullsOnlyBeyondTheTfarItsVisitorSet) {
    const Scene scene = mixed_scene(11);
    Impl a;
    set_frame(a, scene);
    ExactBvh bvh;
    ASSERT_TRUE(bvh.build(a).ok());
    std::mt19937_64 rng(5);
    for (int n = 0; n < 1000; ++n) {
        const FloatRay f = random_ray(a, rng);
        // The visitor lowers tfar to each primitive's box entry plus a little, as a hit there
        // would; every primitive whose box the ray meets well before the final tfar must have
        // been offered.
        std::set<Prim> seen;
        float tfar = f.tfar;
        bvh.closest(f, [&](std::uint32_t object, std::uint32_t prim, float& t) {
            seen.insert({object, prim});
            lower_to_entry(a, f, object, prim, t);
            tfar = t;
            return true;
        });
        expect_none_culled(a, f, tfar, seen, "ray " + std::to_string(n));
    }
}

// The single walk's prefetches (only in trees of 1 MiB or more unless asked for: these are
// smaller) change what is read when, never what is offered: forced on, both walks offer the
// same primitives in the same order as with them off, with spheres, an empty mesh and several
// objects among the leaves (the index rows' object lookup), and with a visitor that culls.
TEST(ExactBvh, PrefetchingChangesNothingTheWalkOffers) {
    for (std::uint64_t seed = 21; seed <= 23; ++seed) {
        const Scene scene = mixed_scene(seed);
        Impl a;
        set_frame(a, scene);
        ExactBvh on, off;
        ASSERT_TRUE(on.build(a, ExactBvh::Prefetch::always).ok());
        ASSERT_TRUE(off.build(a, ExactBvh::Prefetch::never).ok());
        std::mt19937_64 rng(seed);
        std::size_t offered = 0;
        for (int n = 0; n < 500; ++n) {
            const FloatRay f = random_ray(a, rng);
            for (const bool ordered : {false, true}) {
                std::vector<Prim> seen[2];
                for (int k = 0; k < 2; ++k) {
                    auto visit = [&](std::uint32_t object, std::uint32_t prim, float& t) {
                        seen[k].push_back({object, prim});
                        lower_to_entry(a, f, object, prim, t);
                        return true;
                    };
                    const ExactBvh& bvh = k == 0 ? on : off;
                    if (ordered)
                        bvh.closest(f, visit);
                    else
                        bvh.any(f, [&](std::uint32_t object, std::uint32_t prim, float&) {
                            seen[k].push_back({object, prim});
                            return true;
                        });
                }
                EXPECT_EQ(seen[0], seen[1])
                    << "seed " << seed << " ray " << n << " ordered " << ordered;
                offered += seen[0].size();
            }
        }
        EXPECT_GT(offered, 1000u) << "the rays should meet boxes";
    }
}

/// Up to eight rays that run with `first` (ExactBvh::runs_with): its origin, or one a little
/// off it, its direction turned by up to a few hundredths of a degree (a component zero in
/// `first` stays zero, so that the signs stay), each its own range.
std::vector<FloatRay> bundle(const FloatRay& first, std::mt19937_64& rng) {
    std::uniform_real_distribution<double> u(-1.0, 1.0), unit(0.0, 1.0);
    std::vector<FloatRay> rays{first};
    const auto turned = [&](float d) { return static_cast<float>(d * (1.0 + 2e-4 * u(rng))); };
    while (rays.size() < ExactBvh::kWidth) {
        FloatRay f = first;
        if (rng() % 2) {
            f.org_x += static_cast<float>(1e-3 * u(rng));
            f.org_y += static_cast<float>(1e-3 * u(rng));
        }
        f.dir_x = turned(first.dir_x);
        f.dir_y = turned(first.dir_y);
        f.dir_z = turned(first.dir_z);
        if (rng() % 4 == 0)
            f.tfar = static_cast<float>(unit(rng) * 1.5);
        rays.push_back(f);
    }
    return rays;
}

/// f(a, bvh, n, rays, packet) for `count` bundles of rays that run together (and the packet of
/// them), over mixed_scene(`seed`)'s tree.
template <class F>
void for_bundles(std::uint64_t seed, int count, F&& f) {
    const Scene scene = mixed_scene(seed);
    Impl a;
    set_frame(a, scene);
    ExactBvh bvh;
    ASSERT_TRUE(bvh.build(a).ok());
    std::mt19937_64 rng(seed + 100);
    for (int n = 0; n < count; ++n) {
        const std::vector<FloatRay> rays = bundle(random_ray(a, rng), rng);
        ExactBvh::Packet p;
        for (std::size_t k = 0; k < rays.size(); ++k) {
            ASSERT_TRUE(ExactBvh::runs_with(rays[0], rays[k])) << n << " " << k;
            ExactBvh::add_lane(p, static_cast<int>(k), rays[k], nullptr);
        }
        f(a, bvh, n, rays, p);
    }
}

// The packet walk offers each lane what the lane's own walk offers its ray: with a visitor that
// lowers nothing, the same primitives (the box test is the same per lane), on bundles of rays
// that run together.
TEST(ExactBvh, PacketOffersEachLaneWhatItsOwnWalkOffers) {
    if (!cpu_has_avx())
        GTEST_SKIP() << "the packet walk needs AVX";
    long offered = 0;
    for_bundles(
        3, 400,
        [&](const Impl&, const ExactBvh& bvh, int n, const std::vector<FloatRay>& rays,
            ExactBvh::Packet& p) {
            std::vector<std::set<Prim>> together(rays.size()), alone(rays.size());
            bvh.closest_packet(p, [&](int lane, std::uint32_t object, std::uint32_t prim, float&) {
                EXPECT_TRUE(together[static_cast<std::size_t>(lane)].insert({object, prim}).second)
                    << "offered twice";
                return true;
            });
            for (std::size_t k = 0; k < rays.size(); ++k) {
                bvh.closest(rays[k], [&](std::uint32_t object, std::uint32_t prim, float&) {
                    alone[k].insert({object, prim});
                    return true;
                });
                EXPECT_EQ(together[k], alone[k]) << "bundle " << n << " lane " << k;
                offered += static_cast<long>(alone[k].size());
            }
        });
    EXPECT_GT(offered, 2000) << "the rays should meet boxes";  // 4,290 (2026-12-07)
}

// As ClosestWalkCullsOnlyBeyondTheTfarItsVisitorSet, lane by lane in packets: each lane's
// visitor lowers that lane's tfar alone, and nothing a lane's ray meets well before its own
// final tfar is culled.
TEST(ExactBvh, PacketWalkCullsEachLaneOnlyBeyondItsOwnTfar) {
    if (!cpu_has_avx())
        GTEST_SKIP() << "the packet walk needs AVX";
    for_bundles(11, 300,
                [&](const Impl& a, const ExactBvh& bvh, int n, const std::vector<FloatRay>& rays,
                    ExactBvh::Packet& p) {
                    std::vector<std::set<Prim>> seen(rays.size());
                    std::vector<float> tfar(rays.size());
                    for (std::size_t k = 0; k < rays.size(); ++k)
                        tfar[k] = rays[k].tfar;
                    bvh.closest_packet(
                        p, [&](int lane, std::uint32_t object, std::uint32_t prim, float& t) {
                            const auto k = static_cast<std::size_t>(lane);
                            seen[k].insert({object, prim});
                            lower_to_entry(a, rays[k], object, prim, t);
                            tfar[k] = t;
                            return true;
                        });
                    for (std::size_t k = 0; k < rays.size(); ++k)
                        expect_none_culled(
                            a, rays[k], tfar[k], seen[k],
                            "bundle " + std::to_string(n) + " lane " + std::to_string(k));
                });
}

// Rays that diverge are not walked together: a direction beyond the cone, an origin beyond the
// spread, or a sign of a direction's component not the first's.
TEST(ExactBvh, OnlyRaysThatRunTogetherShareAWalk) {
    FloatRay first;
    first.dir_x = 1.0f, first.dir_y = 0.5f, first.dir_z = -0.25f;
    FloatRay f = first;
    EXPECT_TRUE(ExactBvh::runs_with(first, f));
    f.dir_y = 0.52f;  // 0.9° off
    EXPECT_FALSE(ExactBvh::runs_with(first, f));
    f = first;
    f.dir_y = 0.505f;  // 0.22° off
    EXPECT_TRUE(ExactBvh::runs_with(first, f));
    f = first;
    f.org_z = 0.02f;
    EXPECT_FALSE(ExactBvh::runs_with(first, f));
    f = first;
    first.dir_z = 0.0f;
    f.dir_z = -0.0f;  // the walk's nearer plane follows the sign of a zero too
    EXPECT_FALSE(ExactBvh::runs_with(first, f));
}

/// Whether the float ray o + t·d, t in [0, tfar], meets the float box [lo, hi], decided exactly:
/// the slab distances (b − o)/d compared as fractions, cross-multiplied in quad precision (a
/// difference of two floats of this test's magnitudes, and a product of two such, are exact
/// there). A zero direction component keeps the ray inside its slab or outside it.
bool meets_exactly(const float lo[3], const float hi[3], const float o[3], const float d[3],
                   float tfar) {
    using Q = __float128;
    struct Fraction {
        Q num, den;  // den > 0
    };
    const auto le = [](const Fraction& a, const Fraction& b) {
        return a.num * b.den <= b.num * a.den;
    };
    Fraction near{0, 1}, far{tfar, 1};
    bool far_open = std::isinf(tfar);
    for (int k = 0; k < 3; ++k) {
        if (d[k] == 0.0f) {
            if (o[k] < lo[k] || o[k] > hi[k])
                return false;
            continue;
        }
        const Q a = static_cast<Q>(lo[k]) - static_cast<Q>(o[k]);
        const Q b = static_cast<Q>(hi[k]) - static_cast<Q>(o[k]);
        Fraction in{a, d[k]}, out{b, d[k]};
        if (d[k] < 0.0f) {
            in = {-b, -static_cast<Q>(d[k])};
            out = {-a, -static_cast<Q>(d[k])};
        }
        if (le(near, in))
            near = in;
        if (far_open || le(out, far))
            far = out;
        far_open = false;
    }
    return far_open || le(near, far);
}

TEST(ExactBvh, BoxTestNeverCullsABoxTheRayMeets) {
    // Rays aimed at a corner, an edge or a face of lane 0's box (flat boxes among them), tfar at
    // the aimed point or an ulp before it, a direction component sometimes exactly zero with
    // the origin off the box's faces on that axis (on a face, the walk's ±1e-18 may leave the
    // box at t = 0⁺: exact_bvh.h says why no hit is lost there). Every lane the exact
    // evaluation finds met must be met, with AVX and without.
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<float> c(-1.0f, 1.0f), u(0.0f, 1.0f);
    int met = 0;
    for (int n = 0; n < 100000; ++n) {
        ExactBvh::Node node;
        for (int k = 0; k < ExactBvh::kWidth; ++k)
            for (int ax = 0; ax < 3; ++ax) {
                const float x = c(rng) * 0.5f, y = rng() % 4 == 0 ? x : c(rng) * 0.5f;
                node.lo[ax][k] = std::min(x, y);
                node.hi[ax][k] = std::max(x, y);
            }
        float p[3], o[3], d[3];
        for (int ax = 0; ax < 3; ++ax) {
            const auto r = rng() % 3;
            p[ax] = r == 0   ? node.lo[ax][0]
                    : r == 1 ? node.hi[ax][0]
                             : node.lo[ax][0] + u(rng) * (node.hi[ax][0] - node.lo[ax][0]);
            o[ax] = c(rng) * 2.0f;
            d[ax] = p[ax] - o[ax];
        }
        if (rng() % 4 == 0) {
            const auto ax = rng() % 3;
            d[ax] = rng() % 2 ? 0.0f : -0.0f;
            bool on_face = false;
            for (int k = 0; k < ExactBvh::kWidth; ++k)
                on_face = on_face || o[ax] == node.lo[ax][k] || o[ax] == node.hi[ax][k];
            if (on_face)
                continue;
        }
        float tfar = std::numeric_limits<float>::infinity();
        if (rng() % 2)
            tfar = rng() % 2 ? 1.0f : std::nextafter(1.0f, 0.0f);  // p is at t = 1
        const ExactBvh::Lanes r = ExactBvh::lanes_of(o[0], o[1], o[2], d[0], d[1], d[2]);
        ExactBvh::QNode q;
        ASSERT_TRUE(ExactBvh::quantize(node, q));
        for (const int form : {0, 1, 2, 3}) {  // float or quantized, SSE or AVX
            const bool avx = form & 1, quantized = form & 2;
            if (avx && !cpu_has_avx())
                continue;
            alignas(32) float near[8];
            const unsigned mask = quantized ? ExactBvh::meets(q, r, 0.0f, tfar, near, avx)
                                            : ExactBvh::meets(node, r, 0.0f, tfar, near, avx);
            for (int k = 0; k < ExactBvh::kWidth; ++k) {
                const float lo[3] = {node.lo[0][k], node.lo[1][k], node.lo[2][k]};
                const float hi[3] = {node.hi[0][k], node.hi[1][k], node.hi[2][k]};
                if (!meets_exactly(lo, hi, o, d, tfar))
                    continue;
                ++met;
                ASSERT_TRUE(mask >> k & 1u)
                    << "case " << n << " lane " << k << (avx ? " (AVX" : " (SSE")
                    << (quantized ? ", quantized)" : ")") << ": culled a box the ray meets";
            }
        }
    }
    EXPECT_GT(met, 100000);
}

TEST(ExactBvh, AvxAndSseBoxTestsAgree) {
    if (!cpu_has_avx())
        GTEST_SKIP() << "this processor has no AVX: only the SSE box test runs here";
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<float> c(-2.0f, 2.0f);
    for (int n = 0; n < 20000; ++n) {
        ExactBvh::Node node;
        for (int k = 0; k < ExactBvh::kWidth; ++k)
            for (int ax = 0; ax < 3; ++ax) {
                if (rng() % 8 == 0) {  // an empty lane
                    node.lo[ax][k] = std::numeric_limits<float>::infinity();
                    node.hi[ax][k] = -std::numeric_limits<float>::infinity();
                    continue;
                }
                const float x = c(rng), y = c(rng);
                node.lo[ax][k] = std::min(x, y);
                node.hi[ax][k] = std::max(x, y);
            }
        const float dz = rng() % 4 == 0 ? 0.0f : c(rng);
        const ExactBvh::Lanes r = ExactBvh::lanes_of(c(rng), c(rng), c(rng), c(rng), c(rng), dz);
        const float tfar = rng() % 2 ? std::numeric_limits<float>::infinity() : std::abs(c(rng));
        alignas(32) float near_avx[8], near_sse[8];
        ASSERT_EQ(ExactBvh::meets(node, r, 0.0f, tfar, near_avx, true),
                  ExactBvh::meets(node, r, 0.0f, tfar, near_sse, false))
            << "case " << n;
        for (int k = 0; k < 8; ++k)
            ASSERT_TRUE(testing::same_bits(near_avx[k], near_sse[k])) << "case " << n;
        ExactBvh::QNode q;
        ASSERT_TRUE(ExactBvh::quantize(node, q));
        const unsigned m_avx = ExactBvh::meets(q, r, 0.0f, tfar, near_avx, true);
        const unsigned m_sse = ExactBvh::meets(q, r, 0.0f, tfar, near_sse, false);
        ASSERT_EQ(m_avx, m_sse) << "case " << n << ", quantized";
        for (int k = 0; k < 8; ++k) {
            if (m_avx >> k & 1u) {  // an empty lane's distance is never read
                ASSERT_TRUE(testing::same_bits(near_avx[k], near_sse[k]))
                    << "case " << n << ", quantized";
            }
        }
    }
}

TEST(ExactBvh, DegenerateTreesAreWalked) {
    // No primitive at all: nothing offered. One: offered (the root is that leaf). A hundred copies
    // of one triangle (every centre the same: split by index) beside a sphere off the ray: every
    // copy offered, the sphere not.
    for (int copies : {0, 1, 5, 100}) {  // 5: the root is a quantized node
        std::vector<Vec3d> positions;
        std::vector<std::array<std::uint32_t, 3>> triangles;
        for (int i = 0; i < copies; ++i) {
            const auto base = static_cast<std::uint32_t>(positions.size());
            positions.insert(positions.end(), {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
            triangles.push_back({base, base + 1, base + 2});
        }
        Scene scene;
        scene.objects.push_back(testing::mesh_object("m", positions, triangles));
        if (copies > 1)
            scene.objects.push_back(testing::sphere("s", {5, 5, 5}, 0.5, 0));
        Impl a;
        set_frame(a, scene);
        ExactBvh bvh;
        ASSERT_TRUE(bvh.build(a).ok());
        // Down the z axis through the triangle, in Embree's frame.
        const Vec3d o = a.frame({0.25, 0.25, 3.0});
        FloatRay f;
        f.org_x = static_cast<float>(o.x);
        f.org_y = static_cast<float>(o.y);
        f.org_z = static_cast<float>(o.z);
        f.dir_z = -1.0f;
        f.tnear = 0.0f;
        f.tfar = std::numeric_limits<float>::infinity();
        int triangles_offered = 0, spheres_offered = 0;
        bvh.closest(f, [&](std::uint32_t object, std::uint32_t, float&) {
            (object == 0 ? triangles_offered : spheres_offered) += 1;
            return true;
        });
        EXPECT_EQ(triangles_offered, copies);
        EXPECT_EQ(spheres_offered, 0);
    }
}

TEST(ExactBvh, QuantizedBoxesContainTheirNodesWithinAStep) {
    // Each lane's box as the walk forms it from the bytes contains the float box, and exceeds it
    // by at most a step (1/255 of the node's box and a rounding) on each side: random boxes,
    // flat ones, nodes of one box, empty lanes, all lanes empty, and boxes 1e-30 and 1e30 across.
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<float> c(-1.0f, 1.0f);
    for (int n = 0; n < 20000; ++n) {
        const float size = n % 3 == 0 ? 1e-30f : n % 3 == 1 ? 1.0f : 1e30f;
        const float shift = (n % 7) * 0.5f;
        ExactBvh::Node node;
        for (int k = 0; k < ExactBvh::kWidth; ++k) {
            node.child[k] = static_cast<std::uint32_t>(k);
            const bool empty = n % 101 == 0 || (k > 0 && rng() % 5 == 0);
            for (int ax = 0; ax < 3; ++ax) {
                if (empty) {
                    node.lo[ax][k] = std::numeric_limits<float>::infinity();
                    node.hi[ax][k] = -std::numeric_limits<float>::infinity();
                    continue;
                }
                // Tiny boxes at an offset too, a few ulps of it wide (else 1e-30 on 1.5 is a
                // point).
                const float base = n % 5 == 0 ? std::nextafter(shift + 1.0f, 4.0f) : shift;
                const float x = base + c(rng) * size, y = rng() % 4 == 0 ? x : base + c(rng) * size;
                node.lo[ax][k] = std::min(x, y);
                node.hi[ax][k] = std::max(x, y);
            }
        }
        ExactBvh::QNode q;
        ASSERT_TRUE(ExactBvh::quantize(node, q));
        for (int k = 0; k < ExactBvh::kWidth; ++k) {
            const bool empty = !(node.lo[0][k] <= node.hi[0][k]);
            EXPECT_EQ(q.empty >> k & 1u, empty ? 1u : 0u) << "case " << n << " lane " << k;
            if (empty)
                continue;
            float lo[3], hi[3];
            ExactBvh::dequantize(q, k, lo, hi);
            for (int ax = 0; ax < 3; ++ax) {
                ASSERT_LE(lo[ax], node.lo[ax][k])
                    << "case " << n << " lane " << k << " axis " << ax;
                ASSERT_GE(hi[ax], node.hi[ax][k])
                    << "case " << n << " lane " << k << " axis " << ax;
                // A step, and the rounding of origin + q·step (an ulp or two of the plane,
                // more than a step where the box is a few ulps wide).
                const float step = q.scale[ax] * 1.0001f +
                                   2.0f * std::numeric_limits<float>::epsilon() *
                                       std::max(std::abs(lo[ax]), std::abs(hi[ax])) +
                                   1e-37f;
                EXPECT_LE(node.lo[ax][k] - lo[ax], step) << "case " << n << " lane " << k;
                EXPECT_LE(hi[ax] - node.hi[ax][k], step) << "case " << n << " lane " << k;
            }
        }
    }
    // The walk's planes (AVX, SSE) are dequantize's, bit for bit: the box test of a QNode is
    // that of the float node made of its dequantized boxes, mask and distances alike.
    std::mt19937_64 rays(9);
    for (int n = 0; n < 20000; ++n) {
        ExactBvh::Node node;
        const float size = n % 2 ? 1.0f : 1e-3f;
        for (int k = 0; k < ExactBvh::kWidth; ++k) {
            node.child[k] = static_cast<std::uint32_t>(k);
            const bool empty = k > 0 && rays() % 6 == 0;
            for (int ax = 0; ax < 3; ++ax) {
                const float x = 0.5f + c(rays) * size, y = 0.5f + c(rays) * size;
                node.lo[ax][k] = empty ? std::numeric_limits<float>::infinity() : std::min(x, y);
                node.hi[ax][k] = empty ? -std::numeric_limits<float>::infinity() : std::max(x, y);
            }
        }
        ExactBvh::QNode q;
        ASSERT_TRUE(ExactBvh::quantize(node, q));
        ExactBvh::Node planes = node;
        for (int k = 0; k < ExactBvh::kWidth; ++k) {
            if (q.empty >> k & 1u)
                continue;
            float lo[3], hi[3];
            ExactBvh::dequantize(q, k, lo, hi);
            for (int ax = 0; ax < 3; ++ax) {
                planes.lo[ax][k] = lo[ax];
                planes.hi[ax][k] = hi[ax];
            }
        }
        const ExactBvh::Lanes r =
            ExactBvh::lanes_of(c(rays) * 2, c(rays) * 2, c(rays) * 2, c(rays), c(rays), c(rays));
        for (const bool avx : {false, true}) {
            if (avx && !cpu_has_avx())
                continue;
            alignas(32) float near_q[8], near_f[8];
            const unsigned mq = ExactBvh::meets(q, r, 0.0f, 10.0f, near_q, avx);
            const unsigned mf = ExactBvh::meets(planes, r, 0.0f, 10.0f, near_f, avx);
            ASSERT_EQ(mq, mf) << "case " << n << (avx ? " (AVX)" : " (SSE)");
            for (int k = 0; k < ExactBvh::kWidth; ++k) {
                if (!(q.empty >> k & 1u)) {
                    ASSERT_TRUE(testing::same_bits(near_q[k], near_f[k]))
                        << "case " << n << " lane " << k << (avx ? " (AVX)" : " (SSE)");
                }
            }
        }
    }
    // A box that is not finite is refused (the tree is then not built: the linear scan answers).
    ExactBvh::Node bad{};
    for (int k = 0; k < ExactBvh::kWidth; ++k)
        for (int ax = 0; ax < 3; ++ax) {
            bad.lo[ax][k] = 0.0f;
            bad.hi[ax][k] = 1.0f;
        }
    bad.hi[1][3] = std::numeric_limits<float>::infinity();
    ExactBvh::QNode q;
    EXPECT_FALSE(ExactBvh::quantize(bad, q));
}

TEST(ExactBvh, NodesAtTheBottomArePacked) {
    // A node holds kWidth children, and a leaf is a child of its own (no leaf nodes): a tree of
    // n primitives has at least n / (kWidth − 1) nodes. The build cuts ranges of up to kWidth²
    // primitives into groups of kWidth (exact_bvh.cpp, split), so that the nodes at the bottom
    // are full; splitting the largest child down to single primitives, as it did until
    // 2026-12-06, had left them with two to four leaves, and icospheres at about three nodes
    // in eight primitives.
    for (int level : {3, 4, 5}) {
        Scene scene;
        scene.objects.push_back(testing::icosphere_object(level, {1.0, -0.5, 0.5}, 3.0));
        Impl a;
        set_frame(a, scene);
        ExactBvh bvh;
        ASSERT_TRUE(bvh.build(a).ok());
        const double prims = static_cast<double>(scene.objects[0].primitive_count());
        const double nodes = static_cast<double>(bvh.node_count());
        EXPECT_LT(nodes, prims / 5.0) << "level " << level << ": " << nodes << " nodes";
    }
}

}  // namespace
}  // namespace raycastd::engine::embree
