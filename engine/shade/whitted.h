#pragma once
// Whitted-style ray tracing (Whitted, "An Improved Illumination Model for Shaded Display",
// CACM 23(6), 1980) with the Phong model at every surface point, as the tutorial teaches it:
//
//   I = ka·Ia + Σ_lights [shadow ray free] · Ip·(kd·(N·L) + ks·(R·V)ⁿ)
//         + reflectivity · I(reflected ray) + transparency · I(refracted ray)
//
// * One shadow ray per point or directional light whose light is in front of the shading
//   normal; any object between the point and the light blocks it (transparent ones too, as in
//   the classic model).
// * The shading normal is turned to face the incoming ray, so a glass exit point or a triangle
//   seen from behind is lit from the side the ray is on.
// * Reflection: the mirror direction, weighted by `reflectivity`. Refraction: Snell's law with
//   η = 1/ior entering (front face) and ior leaving; on total internal reflection no light is
//   transmitted. Following the tutorial, internal reflection inside a transparent object is not
//   traced: at a point where the ray leaves a transparent object only the refracted ray goes on.
// * Recursion stops at `max_depth` surface points along a path (the camera ray's hit is 1).
// * Work the scene does not need is skipped, decided once per scene (ShadingPlan): no shadow rays
//   without point/directional lights, no reflected/refracted rays where no material reflects or
//   refracts, no specular power where ks = 0.
//
// All tracing goes through a Tracer over the QueryEngine (query/tracer.h: closest for camera
// and secondary rays, occluded for shadow rays) at the precision asked for, which also says how
// much float rounding spawned origins must clear; secondary rays start at robust origins
// (shade/spawn.h). Renders ask for a tracer built for many rays (many_rays), which
// scans a scene QueryEngine answers by brute force through a flat copy of its own.

#include <cstdint>
#include <optional>
#include <vector>

#include "engine/cancel.h"
#include "engine/query/intersect.h"
#include "engine/query/tracer.h"
#include "engine/shade/spawn.h"

namespace raycastd::engine {

struct WhittedOptions {
    int max_depth = 5;  ///< surface points along one path (1: camera hits only)
    Precision precision = Precision::refined;
    Vec3d background{0.0, 0.0, 0.0};  ///< the colour of a ray that hits nothing
    /// A headlight in place of the scene's lights (a render's `lighting`, docs/api.md): ambient
    /// 0.1 plus a directional light of intensity 0.9 travelling along this unit direction, the
    /// camera's view direction. Camera hits trace no shadow ray for it (the light comes from the
    /// eye's side, so what the eye sees is lit); deeper hits trace theirs. nullopt: the scene's
    /// own lights (ray trees always use those).
    std::optional<Vec3d> headlight;
    /// Trace through a Tracer built for many rays (BuildHint::many_rays): a scene QueryEngine
    /// answers by brute force gets a scan of its own (renders: millions of rays). Off for a
    /// single ray tree, where QueryEngine's brute force is the cheapest.
    bool many_rays = false;
    /// shade_hits() traces each generation of rays as a batch (Embree packets); off, it shades
    /// hit by hit as shade_hit() does (the tests and bench_render --single-rays compare them).
    /// Scenes the tracer scans itself (at most 16 primitives) are shaded hit by hit either way
    /// (a scan has no packets to gain from batches, whitted.cpp).
    bool trace_in_batches = true;
};

/// Rays traced, by kind.
struct RayCounts {
    std::uint64_t primary = 0;
    std::uint64_t shadow = 0;
    std::uint64_t reflected = 0;
    std::uint64_t refracted = 0;

    RayCounts& operator+=(const RayCounts& o) {
        primary += o.primary;
        shadow += o.shadow;
        reflected += o.reflected;
        refracted += o.refracted;
        return *this;
    }
    std::uint64_t total() const { return primary + shadow + reflected + refracted; }
};

/// What shading a scene needs, decided once per scene (and per headlight).
struct ShadingPlan {
    /// Ia: the sum of the ambient lights; 1 when the scene has no lights at all; 0.1 with a
    /// headlight
    Vec3d ambient;
    /// indices of the point and directional lights (none with a headlight)
    std::vector<std::uint32_t> shadow_lights;
    /// per shadow_lights[k]: for a directional light the unit direction towards it,
    /// normalize(−direction), the same at every point and so made once here (it had been made
    /// per hit, a normalisation of the Duck's directional light at each of its hits); unused
    /// (zero) for a point light
    std::vector<Vec3d> towards_directional;
    std::optional<Light> headlight;  ///< the directional headlight, in place of the scene's lights
    bool reflection = false;         ///< some material reflects
    bool refraction = false;         ///< some material is transparent
    std::vector<bool> specular;      ///< per material: ks ≠ 0
};

/// Ambient intensity and directional intensity of the headlight (docs/api.md, render `lighting`).
constexpr double kHeadlightAmbient = 0.1;
constexpr double kHeadlightIntensity = 0.9;

/// Decides the plan for `scene`; with a `headlight` direction (unit, the direction the light
/// travels) the scene's lights are replaced by kHeadlightAmbient and that light.
ShadingPlan plan_shading(const Scene& scene, const std::optional<Vec3d>& headlight = std::nullopt);

/// One shadow ray of a tree node.
struct ShadowRayRecord {
    std::uint32_t light = 0;                ///< index into Scene::lights
    std::uint32_t blocked_by = kInvalidId;  ///< the closest object in the way, or kInvalidId
    bool facing = false;  ///< the light is in front of the shading normal (else no ray is traced)
};

/// A surface point where intensity is computed (a node of the ray tree).
struct TreeNode {
    Hit hit;       ///< as the query answered it (geometric normal as stored, front_face)
    Vec3d point;   ///< hit_point (query/intersect.h): ray.at(hit.t), or on the surface from afar
    Vec3d normal;  ///< the shading normal, turned to face the incoming ray
    std::vector<ShadowRayRecord> shadow_rays;
    bool full_phong = false;  ///< some light contributes: ambient + diffuse + specular
    Vec3d color;              ///< the intensity at this point, children included
    int reflected = -1;       ///< index of the reflected child in RayTree::nodes, −1 for none
    int refracted = -1;       ///< index of the refracted child, −1 for none
    bool total_internal_reflection = false;  ///< refraction was asked for but none exists
};

/// The Whitted ray tree of one ray: nodes in depth-first order (reflected before refracted),
/// so that node k is the tutorial's I(k+1). Empty when the ray hits nothing.
struct RayTree {
    std::vector<TreeNode> nodes;
    Vec3d color;  ///< the ray's intensity (the root's colour, or the background)
    RayCounts counts;
};

/// A Whitted tracer over one prepared scene; immutable, shared by the threads of a render.
class Whitted {
  public:
    Whitted(const QueryEngine& engine, WhittedOptions options);

    const ShadingPlan& plan() const { return plan_; }
    const WhittedOptions& options() const { return options_; }
    const Scene& scene() const { return engine_.scene(); }

    /// The closest hit along `ray` (normal included), or nullopt.
    std::optional<Hit> closest(const Ray& ray) const;
    /// Closest hits of a batch (a tile's camera rays, coherent in runs of 16) into out[0..n);
    /// a miss leaves an invalid Hit.
    void closest_batch(const std::vector<Ray>& rays, std::vector<Hit>& out) const;
    /// The same for rays[0..n) into out[0..n) (a caller's reused buffer).
    void closest_batch(const Ray* rays, std::size_t n, Hit* out) const;
    /// Whether anything lies along `ray` within [tmin, tmax].
    bool occluded(const Ray& ray) const;

    /// The intensity (linear RGB) along a camera ray; adds the rays traced to `counts`.
    Vec3d radiance(const Ray& ray, RayCounts& counts) const;
    /// The same, shading a camera hit already found (counts.primary is the caller's).
    Vec3d shade_hit(const Ray& ray, const Hit& hit, RayCounts& counts) const;
    /// shade_hit() for each of a batch of camera hits, into out[0..n) (a miss: the background),
    /// traced generation by generation (a wavefront): the hits' shadow rays together, light by
    /// light in the order of the hits, so that neighbouring hits' rays to one light form
    /// coherent runs of 16 that the tracer answers as Embree occlusion packets
    /// (Tracer::occluded_batch); then all their reflected rays as one closest-hit batch, and
    /// all their refracted rays as another, whose hits are shaded the same way one level
    /// deeper. The colours are shade_hit()'s, up to which path decided a ray (equal at
    /// `exact`).
    void shade_hits(const std::vector<Ray>& rays, const std::vector<Hit>& hits,
                    std::vector<Vec3d>& out, RayCounts& counts) const;
    /// The same for rays[0..n) and hits[0..n) into out[0..n).
    void shade_hits(const Ray* rays, const Hit* hits, std::size_t n, Vec3d* out,
                    RayCounts& counts) const;
    /// Frees the batch buffers shade_hits() keeps on the calling thread for its next batches
    /// (engine/thread_scratch.h: ThreadScratch::release_all).
    static void release_thread_scratch();
    /// The bytes of those buffers the calling thread keeps (0 after release_thread_scratch()).
    static std::size_t thread_scratch_bytes();
    /// The ray tree of one ray, with the blocking object of each shadow ray named;
    /// Code::cancelled once `cancel` has fired (it is asked once per node).
    Result<RayTree> tree(const Ray& ray, const CancelToken& cancel = {}) const;

    /// The path that answers this tracer's queries (Tracer::precision).
    Precision effective_precision() const { return tracer_.precision(); }

    /// The material index of a hit (per-triangle material when the mesh has them).
    std::uint32_t material_of(const Hit& hit) const;
    /// The unit shading normal of a hit as stored, not yet turned towards the ray: on a mesh,
    /// its vertex normals interpolated with the hit's barycentrics (u, v) as
    /// (1−u−v)·n₀ + u·n₁ + v·n₂, normalized; the file's normals where it has them, else the
    /// computed ones (QueryEngine::computed_normals: area-weighted, split at creases). The
    /// geometric normal for spheres, lone triangles, and where the interpolation vanishes.
    Vec3d shading_normal(const Hit& hit) const;
    /// The linear colour of material `m`'s texture at a hit's (u, v), which multiplies its
    /// diffuse and ambient colours (docs/api.md, render); none when `m` has no texture or the
    /// mesh has no texture coordinates.
    std::optional<Vec3d> texel(const Hit& hit, const Material& m) const;

  private:
    struct Surface;  // a hit made ready for shading (whitted.cpp)
    /// The directions a surface point sends rays in: the mirror direction unless it leaves
    /// glass, the refracted one unless there is total internal reflection (spawn() makes the
    /// rays). Directions rather than rays: two optional Rays were 152 bytes, which GCC cleared
    /// with `rep stos` on every call (a quarter of the function's samples, perf annotate).
    struct SecondaryRays {
        std::optional<Vec3d> reflected, refracted;
        bool total_internal_reflection = false;
    };
    struct TreeBuild;  // a ray tree being built, and its token (whitted.cpp)
    /// The hit's vertex normals interpolated (shading_normal's sum), not yet normalized, in
    /// `n`; false where the hit has none (spheres, lone triangles).
    bool interpolated_normal(const Hit& hit, Vec3d& n) const;
    /// A surface point's direction to one light, whether the light is in front of its shading
    /// normal, and whether its shadow ray is blocked (traced by shade_batch for direct()).
    struct ToLight {
        /// Towards the light: a directional light's unit direction, or for a point light the
        /// light's position minus the point, not yet normalised (unit_towards() normalises it
        /// where it is used: a facing light whose shadow ray is free).
        Vec3d l;
        bool facing = false;
        bool blocked = false;
    };

    Vec3d trace(const Ray& ray, int depth, RayCounts& counts, TreeBuild* tree, int* slot) const;
    Vec3d shade(const Ray& ray, const Hit& hit, int depth, RayCounts& counts,
                TreeBuild* tree) const;
    /// The hit made ready for shading.
    Surface surface(const Ray& ray, const Hit& hit, int depth) const;
    /// shade_hits() at `depth` (1: camera hits).
    void shade_batch(const Ray* rays, const Hit* hits, std::size_t n, int depth, Vec3d* out,
                     RayCounts& counts) const;
    struct BatchScratch;  // shade_batch's buffers, reused batch after batch (whitted.cpp)
    SecondaryRays secondary_rays(const Surface& sp) const;
    /// The ray leaving a surface point in direction `w` (spawn_ray's, from the point's robust
    /// origin for w's side, formed once a side: SpawnOrigins).
    static Ray spawn(const Surface& sp, const Vec3d& w);
    /// The same, written into `r` (a batch's own slot: spawn.h says why).
    static void spawn(Ray& r, const Surface& sp, const Vec3d& w);
    /// The direction from a surface point to plan().shadow_lights[k], a point or directional
    /// light (ToLight::l), and whether the light is in front of the shading normal (`blocked`
    /// left false).
    inline ToLight towards_light(const Surface& sp, const Light& light, std::size_t k) const;
    /// The unit direction to `light` of a towards_light() answer.
    static Vec3d unit_towards(const ToLight& t, const Light& light) {
        return light.type == LightType::point ? normalize(t.l) : t.l;
    }
    /// The shadow ray from a surface point to a light whose direction is `l` (towards_light()'s
    /// ToLight::l); only traced when the light is in front of the shading normal.
    Ray shadow_ray(const Surface& sp, const Light& light, const Vec3d& l) const;
    /// The same, written into `r`.
    inline void shadow_ray(Ray& r, const Surface& sp, const Light& light, const Vec3d& l) const;
    /// Emission, ambient, and the diffuse and specular terms of each light whose shadow ray is
    /// free; `lit` says whether any light contributed. Records shadow rays in `node` if given.
    /// `traced`, when given, holds for each plan().shadow_lights[k] its towards_light() and
    /// whether its shadow ray is blocked, already traced (and counted) by the caller; else
    /// direct() computes and traces them.
    Vec3d direct(const Surface& sp, RayCounts& counts, TreeNode* node, bool& lit,
                 const ToLight* traced = nullptr) const;
    /// The headlight's diffuse and specular terms (zero when it is behind N or, below the camera
    /// hit, its shadow ray is blocked).
    Vec3d headlight_terms(const Surface& sp, RayCounts& counts, bool& lit) const;
    /// The diffuse and specular terms of a light in unit direction `l` (phong_light() with
    /// the surface's textured kd).
    inline Vec3d lit_by(const Surface& sp, const Vec3d& l, const Vec3d& intensity) const;
    /// The weighted reflected and refracted rays (below max_depth); children go into node k.
    Vec3d indirect(const Surface& sp, int depth, RayCounts& counts, TreeBuild* tree,
                   std::size_t k) const;

    const QueryEngine& engine_;
    WhittedOptions options_;
    Tracer tracer_;
    ShadingPlan plan_;
    /// Per object, the computed shading normals of a mesh without its own (else nullptr),
    /// fetched once here so that a hit costs no lookup beyond an index.
    std::vector<const CornerNormals*> computed_normals_;
};

}  // namespace raycastd::engine
