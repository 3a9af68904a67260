#pragma once
// exact's BVH: a tree of our own over every primitive's padded float box, walked with the float
// ray prepare_ray sets up, every candidate decided by the double kernels (keep_candidates and
// occludes, user_geometry.h). Until 2026-12-06 this was an Embree scene of user geometry, whose
// tree (Embree's BVH8<object>) held about one leaf per primitive and took 91–106 B a triangle of
// resident memory (issue 17's target is 130 B for everything; docs/numerics.md).
//
// The boxes are those Embree had (primitive_box: the double box relative to the scene centre,
// padded by Impl::pad, in Embree's frame, rounded outward to float), so a float ray within the
// padding of the double one cannot cull a double hit (embree_accel.cpp, the padding). The walk
// tests a node's eight boxes at once with the slab test (Kay & Kajiya 1986) in float, kept
// conservative as Embree's ROBUST traversal keeps it (Ize, "Robust BVH Ray Traversal", JCGT 2(2),
// 2013): each slab distance (b − o)·(1/d) is three roundings off the real one, a relative error
// below 3u_f + O(u_f²), so a box is kept when tnear·(1 − 3ε) ≤ tfar·(1 + 3ε) (ε = 2u_f), with
// room to spare (`ExactBvh.BoxTestNeverCullsABoxTheRayMeets` checks it against exact
// arithmetic). A direction component below 1e-18 in magnitude is replaced by ±1e-18 (its
// reciprocal then finite, so no 0·∞ = NaN). That tilts the ray by at most 1e-18 over a segment
// of a few frame units, far below the padding; and where the component is zero and the origin
// lies exactly on a face of a box, the tilted ray may leave the box at t = 0⁺ where the real one
// runs along the face. Neither loses a hit: a box's faces lie a pad beyond its primitive, and
// the double ray stays within a quarter pad of the float one (exact_ray_within_padding).
//
// The tree is built by binned SAH (Wald, "On fast Construction of SAH-based Bounding Volume
// Hierarchies", RT 2007; 32 bins on the centres' longest axis), eight children a node (the child
// of largest surface area split next, as Embree widens its trees), a leaf for each primitive,
// held in its parent's child code (no array of references to read on the way). Ranges of up to
// 64 primitives are cut into groups of eight (the SAH's cheapest cut among those after a
// multiple of eight, on the sorted centres), so that the nodes at the bottom, most of the tree,
// are full: 38 B a triangle on A and 37 on B, where splitting down to single primitives had
// left them two to four leaves and taken 77 and 61. Those nodes, whose children are all leaves
// (seven in ten), are kept quantized (QNode: a byte a plane, in 128 bytes against 224; Mahovsky
// & Wyvill, "Memory-Conserving Bounding Volume Hierarchies with Coherent Ray Tracing", CGF 25(2),
// 2006; Embree's quantized nodes, kernels/bvh/bvh_node_qaabb.h, are the same idea), rounded
// outward so that each box contains the float one: the tree takes 27 B a triangle on A and 26
// on B. The other nodes, which every walk passes more of, stay in float, so that the walk pays
// the bytes' conversion only at the bottom.

#include <cmath>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "engine/accel/embree/user_geometry.h"
#include "engine/geometry/mesh.h"
#include "engine/geometry/woop_edges.h"
#include "engine/status.h"

namespace raycastd::engine::embree {

struct Impl;

class ExactBvh {
  public:
    static constexpr int kWidth = 8;

    /// Whether the single walk prefetches the children it will come back to (walk_in_order):
    /// where the tree is large enough for it to pay (kPrefetchFromBytes), the default; or
    /// always or never (tests: the answers are the same either way).
    enum class Prefetch { when_large, always, never };
    /// The tree over every primitive of a's scene (its spheres, and every triangle of its
    /// meshes); too_large, and no tree, where the scene has more primitives than a leaf's code
    /// can address (2^31 − 1) or the memory runs out (the caller then scans linearly).
    Status build(const Impl& a, Prefetch prefetch = Prefetch::when_large);

    /// Walks the tree with `f` (a FloatRay: float_ray.h, which includes the header that
    /// includes this one), nearest box first, calling visit(object, prim, tfar) for each
    /// primitive whose box meets the ray's [tnear, tfar] (and for the only primitive of a tree
    /// of one, whose root is that leaf: offered untested); visit may lower tfar (the walk then
    /// culls by it) and returns false to end the walk.
    /// With `woop` (the first stage of Woop's test formed for the double ray the visitor
    /// decides on, in the scene's own coordinates: woop_edges.h), a triangle whose edge
    /// functions alone settle a miss is not offered: the visitor's double test would find no
    /// hit on it (woop_misses, the same bits). On A's camera rays that is 1.9 of 2.76
    /// candidates a ray, each of which had cost a call, the triangle's read into a Triangle,
    /// and the rest of Woop's test.
    template <class FloatRay, class Visit>
    void closest(const FloatRay& f, Visit&& visit, const WoopRay* woop = nullptr) const {
        walk(lanes_of(f.org_x, f.org_y, f.org_z, f.dir_x, f.dir_y, f.dir_z), f.tnear, f.tfar,
             /*ordered=*/true, &call<std::remove_reference_t<Visit>>, &visit, woop);
    }
    /// The same in no particular order (an occlusion query: the first hit ends it; or all hits).
    template <class FloatRay, class Visit>
    void any(const FloatRay& f, Visit&& visit, const WoopRay* woop = nullptr) const {
        walk(lanes_of(f.org_x, f.org_y, f.org_z, f.dir_x, f.dir_y, f.dir_z), f.tnear, f.tfar,
             /*ordered=*/false, &call<std::remove_reference_t<Visit>>, &visit, woop);
    }

    /// The tree's nodes (inner and quantized).
    std::size_t node_count() const { return nodes_.size() + bottom_.size(); }
    /// Bytes the tree holds.
    std::size_t memory_bytes() const {
        return nodes_.capacity() * sizeof(Node) + bottom_.capacity() * sizeof(QNode) +
               first_.capacity() * sizeof(std::uint32_t) +
               meshes_.capacity() * sizeof(const TriangleMesh*);
    }

    /// Eight children's boxes, lane by lane, and what each child is: an inner node's index, a
    /// primitive (kLeafBit | its index among the scene's, first_), or kNoChild, whose box is
    /// empty (lo = +∞, hi = −∞). The build makes every node so; the tree keeps those with an
    /// inner child so, and those whose children are all leaves as QNodes.
    struct alignas(32) Node {
        float lo[3][kWidth], hi[3][kWidth];
        std::uint32_t child[kWidth];
    };
    /// A node of leaves as the tree keeps it, in two cache lines instead of four: each plane a
    /// byte, origin + q·scale on its axis (a float product and a float sum, as the walk forms
    /// them), rounded outward so that the box it gives contains the Node's (quantize). At the
    /// bottom of the tree, where a node's eight primitives share its box, a step of scale is 1/255
    /// of that box, about a hundredth of a primitive's own.
    struct alignas(64) QNode {
        float origin[3], scale[3];
        std::uint8_t lo[3][kWidth], hi[3][kWidth];
        std::uint32_t child[kWidth];
        std::uint8_t empty;  ///< bit k: lane k has no child (its bytes give no box)
    };
    /// `n` quantized; false where a box is not finite (the tree is then not built).
    static bool quantize(const Node& n, QNode& q);
    /// Lane k's box of `q`, as the walk forms it.
    static void dequantize(const QNode& q, int k, float lo[3], float hi[3]);
    /// The ray as the box test takes it: origin, reciprocal direction, and which of a node's
    /// planes it meets first on each axis (hi where the direction is negative).
    struct Lanes {
        float org[3], inv[3];
        bool neg[3];
    };
    /// The float ray (origin, direction) as Lanes; a direction component below 1e-18 in
    /// magnitude taken as ±1e-18 (the file comment).
    static Lanes lanes_of(float ox, float oy, float oz, float dx, float dy, float dz);
    /// Up to eight rays walked together (closest_packet): their float rays lane by lane, as
    /// lanes_of takes each, sharing the signs of their directions (so one plane of each axis is
    /// every lane's nearer), with a first stage of Woop's test for each lane's pre-test (or
    /// none) as closest's `woop`.
    struct Packet {
        alignas(32) float org[3][kWidth];
        alignas(32) float inv[3][kWidth];
        alignas(32) float tnear[kWidth];
        alignas(32) float tfar[kWidth];
        bool neg[3] = {false, false, false};
        unsigned active = 0;  ///< bit k: lane k is walked
        const WoopRay* woop[kWidth] = {};
    };
    /// Whether the float ray `f` (Embree's frame: the scene 1 to 2 units across) runs with
    /// `first` closely enough to share its walk: the same signs of direction (lanes_of's
    /// nearer planes), within kPacketCone of its direction, its origin within kPacketSpread of
    /// `first`'s (camera rays a few pixels apart). Rays that diverge more meet too few nodes in
    /// common for a packet to pay: A's random rays in packets of whatever shared their signs ran
    /// at 3.6 Mrays/s against 4.5 alone (a single-threaded probe). The answers are the same
    /// either way.
    template <class FloatRay>
    static bool runs_with(const FloatRay& first, const FloatRay& f) {
        const float d0[3] = {first.dir_x, first.dir_y, first.dir_z};
        const float o0[3] = {first.org_x, first.org_y, first.org_z};
        const float d[3] = {f.dir_x, f.dir_y, f.dir_z};
        const float o[3] = {f.org_x, f.org_y, f.org_z};
        float dd = 0.0f, n0 = 0.0f, n = 0.0f;
        for (int a = 0; a < 3; ++a) {
            if (std::signbit(d[a]) != std::signbit(d0[a]) ||
                !(std::abs(o[a] - o0[a]) <= kPacketSpread))
                return false;
            dd += d[a] * d0[a];
            n0 += d0[a] * d0[a];
            n += d[a] * d[a];
        }
        return dd > 0.0f && dd * dd >= kPacketCone * kPacketCone * n0 * n;
    }
    /// Lane k of `p` from the float ray `f`, walked with `woop` (or none). Every lane of a
    /// packet must run with its first (runs_with), whose direction's signs are the packet's.
    template <class FloatRay>
    static void add_lane(Packet& p, int k, const FloatRay& f, const WoopRay* woop) {
        add_lane(p, k, lanes_of(f.org_x, f.org_y, f.org_z, f.dir_x, f.dir_y, f.dir_z), f.tnear,
                 f.tfar, woop);
    }
    static void add_lane(Packet& p, int k, const Lanes& r, float tnear, float tfar,
                         const WoopRay* woop);
    /// The cosine of the widest angle between a packet's first direction and another's.
    static constexpr float kPacketCone = 0.9999f;  // 0.8°
    /// The farthest a packet's origin lies from its first, by coordinate, in frame units.
    static constexpr float kPacketSpread = 1.0f / 64.0f;
    /// closest(f, visit, woop) for each lane of `p` at once, with AVX (the processor must have
    /// it): visit(lane, object, prim, tfar) for each primitive whose box meets that lane's
    /// [tnear, tfar], nearest boxes first (by their nearest lane); visit may lower the lane's
    /// tfar. With a visitor that lowers nothing, each lane is offered exactly what closest
    /// would offer its ray; one that lowers tfar culls each lane by its own, in an order that
    /// follows the nearest lane, so what is culled may differ from the lane's own walk, but
    /// never a primitive the lane meets before its final tfar, and the answer (the first by
    /// `closer`, a total order, with tfar_for's margin above it) is the same. What the lanes
    /// share is the walk through the nodes more than one of them meets (a camera's rays).
    template <class Visit>
    void closest_packet(Packet& p, Visit&& visit) const {
        walk_packet(p, &call_lane<std::remove_reference_t<Visit>>, &visit);
    }

    /// The box test: bit k for each child k of `n` whose box meets [tnear, tfar] (tnear ≥ 0),
    /// its entry distance, rounded down, in near[k]. With AVX (the CPU must have it) or as two
    /// SSE halves: the same operations, so the same answers. The walk takes AVX where the CPU
    /// has it.
    static unsigned meets(const Node& n, const Lanes& r, float tnear, float tfar, float near[8],
                          bool avx);
    /// The same for a quantized node (its lanes' boxes as dequantize gives them).
    static unsigned meets(const QNode& n, const Lanes& r, float tnear, float tfar, float near[8],
                          bool avx);

  private:
    static constexpr std::uint32_t kLeafBit = 0x80000000u;
    static constexpr std::uint32_t kNoChild = 0xFFFFFFFFu;
    /// In an inner child's code: the child is bottom_[code & ~kBottomBit], not nodes_[code].
    static constexpr std::uint32_t kBottomBit = 0x40000000u;
    /// Deepest SAH level: below it the build splits at the median (a node's first split halves
    /// its primitives) down to 64 primitives, which take two levels more (their cuts fall after
    /// multiples of eight, so a node of eight children has none of more than eight), so a tree
    /// of fewer than 2^31 primitives is at most kSahDepth + 31 nodes deep, each pushing at most
    /// kWidth − 1 entries beyond the one it takes.
    static constexpr int kSahDepth = 32;
    static constexpr int kStack = (kWidth - 1) * (kSahDepth + 31) + kWidth;

    struct Entry {
        std::uint32_t code;
        float tnear;  ///< rounded down (meets)
    };

    /// A visitor behind a plain function pointer, so that the walk is compiled once, in
    /// exact_bvh.cpp, with its box test for AVX and without; a call per primitive costs little
    /// beside the double test behind it.
    using VisitFn = bool (*)(void* visit, std::uint32_t object, std::uint32_t prim, float& tfar);
    template <class Visit>
    static bool call(void* visit, std::uint32_t object, std::uint32_t prim, float& tfar) {
        return (*static_cast<Visit*>(visit))(object, prim, tfar);
    }
    void walk(const Lanes& r, float tnear, float tfar, bool ordered, VisitFn fn, void* visit,
              const WoopRay* woop) const;
    using LaneVisitFn = bool (*)(void* visit, int lane, std::uint32_t object, std::uint32_t prim,
                                 float& tfar);
    template <class Visit>
    static bool call_lane(void* visit, int lane, std::uint32_t object, std::uint32_t prim,
                          float& tfar) {
        return (*static_cast<Visit*>(visit))(lane, object, prim, tfar);
    }
    void walk_packet(Packet& p, LaneVisitFn fn, void* visit) const;
    /// A primitive's object and its index in it (g: its index among the scene's).
    std::uint32_t object_of(std::uint32_t g) const;
    /// Whether the pre-test with `woop` (none: no pre-test) settles primitive `prim` of `object`
    /// as missed: woop_misses_avx where `avx` (the caller compiled for AVX), else woop_misses.
    template <bool avx>
    bool pretest_misses(std::uint32_t object, std::uint32_t prim, const WoopRay* woop) const;
    /// Prefetches each inner node among the children `mask` picks of `child` (an inner
    /// node's), every cache line of it.
    inline void prefetch_nodes(const std::uint32_t* child, unsigned mask) const;
    /// Prefetches the index row of each mesh triangle among the leaves `mask` picks of `child`
    /// (a bottom node's), which the pre-test or the visitor reads first.
    inline void prefetch_leaves(const std::uint32_t* child, unsigned mask) const;
    Status build_tree(const Impl& a, Prefetch prefetch);
    void walk_avx(const Lanes& r, float tnear, float tfar, bool ordered, VisitFn fn, void* visit,
                  const WoopRay* woop) const;
    void walk_sse(const Lanes& r, float tnear, float tfar, bool ordered, VisitFn fn, void* visit,
                  const WoopRay* woop) const;
    template <bool ordered, bool avx>
    void walk_in_order(const Lanes& r, float tnear, float tfar, VisitFn fn, void* visit,
                       const WoopRay* woop) const;

    friend struct ExactBvhBuilder;
    std::vector<Node> nodes_;    ///< the inner nodes with an inner child
    std::vector<QNode> bottom_;  ///< the nodes whose children are all leaves (kBottomBit)
    /// first_[i]: the index of object i's first primitive among the scene's; one more entry, the
    /// total.
    std::vector<std::uint32_t> first_;
    /// meshes_[i]: object i's mesh, or null for a sphere (the walk's pre-test of a triangle).
    std::vector<const TriangleMesh*> meshes_;
    std::uint32_t root_ = kNoChild;  ///< an inner node, a leaf, or kNoChild (no primitives)
    /// The single walk's prefetches (walk_in_order) pay only where the tree does not stay in
    /// the cache: from this many bytes of nodes (a core's L2 here is 1 MiB; A's tree is 2.2 MB,
    /// B's 26 MB; the bench's C, 1,000 spheres in a few tens of KB, lost 10–15% of its random
    /// rays' speed to them: docs/numerics.md).
    static constexpr std::size_t kPrefetchFromBytes = std::size_t{1} << 20;
    /// when_large: the tree has at least kPrefetchFromBytes of nodes.
    bool prefetch_nodes_ = false;
    /// when_large: that, and the scene is one object, whose leaves' index rows are found
    /// without object_of's search (on C, those searches were about half of the loss).
    bool prefetch_rows_ = false;
};

}  // namespace raycastd::engine::embree
