#include "engine/shade/whitted.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "engine/shade/optics.h"
#include "engine/shade/phong.h"
#include "engine/thread_scratch.h"

namespace raycastd::engine {

namespace {

bool is_nonzero(const Vec3d& v) {
    return v.x > 0.0 || v.y > 0.0 || v.z > 0.0;
}

/// What the hit's barycentrics (u, v) make of values at the triangle's corners:
/// (1 − u − v)·a + u·b + v·c (shading normals, texture coordinates).
template <class T>
T at_hit(const Hit& hit, const T& a, const T& b, const T& c) {
    return a * (1.0 - hit.u - hit.v) + b * hit.u + c * hit.v;
}

/// n / |n|, or `otherwise` where n vanishes (an interpolated normal whose corners cancel),
/// overflows or is NaN.
Vec3d unit_or(const Vec3d& n, const Vec3d& otherwise) {
    const double len = length(n);
    if (!(len > 0.0) || !std::isfinite(len))
        return otherwise;
    return n / len;
}

}  // namespace

ShadingPlan plan_shading(const Scene& s, const std::optional<Vec3d>& headlight) {
    ShadingPlan plan;
    for (const Material& m : s.materials) {
        plan.reflection = plan.reflection || m.reflectivity > 0.0;
        plan.refraction = plan.refraction || m.transparency > 0.0;
        plan.specular.push_back(is_nonzero(m.specular));
    }
    if (headlight) {
        // The headlight replaces the scene's lights entirely (docs/api.md, render `lighting`).
        plan.ambient = Vec3d{kHeadlightAmbient, kHeadlightAmbient, kHeadlightAmbient};
        Light h;
        h.type = LightType::directional;
        h.direction = *headlight;
        h.intensity = Vec3d{kHeadlightIntensity, kHeadlightIntensity, kHeadlightIntensity};
        plan.headlight = h;
        return plan;
    }
    // The API's default (docs/api.md): "no lights = ambient 1.0 only".
    plan.ambient = s.lights.empty() ? Vec3d{1.0, 1.0, 1.0} : Vec3d{};
    for (std::uint32_t i = 0; i < s.lights.size(); ++i) {
        if (s.lights[i].type == LightType::ambient) {
            plan.ambient += s.lights[i].intensity;
        } else if (is_nonzero(s.lights[i].intensity) && !s.objects.empty()) {
            plan.shadow_lights.push_back(i);
            plan.towards_directional.push_back(s.lights[i].type == LightType::directional
                                                   ? normalize(-s.lights[i].direction)
                                                   : Vec3d{});
        }
    }
    return plan;
}

Whitted::Whitted(const QueryEngine& engine, WhittedOptions options)
    : engine_(engine),
      options_(options),
      tracer_(engine, options.precision,
              options.many_rays ? BuildHint::many_rays : BuildHint::few_rays),
      plan_(plan_shading(engine.scene(), options.headlight)) {
    const auto n = static_cast<std::uint32_t>(engine.scene().objects.size());
    computed_normals_.reserve(n);
    for (std::uint32_t i = 0; i < n; ++i)
        computed_normals_.push_back(engine.computed_normals(i));
}

std::optional<Hit> Whitted::closest(const Ray& ray) const {
    return tracer_.closest(ray, /*want_normal=*/true);
}

void Whitted::closest_batch(const std::vector<Ray>& rays, std::vector<Hit>& out) const {
    tracer_.closest_batch(rays, out);
}

void Whitted::closest_batch(const Ray* rays, std::size_t n, Hit* out) const {
    tracer_.closest_batch(rays, n, out);
}

bool Whitted::occluded(const Ray& ray) const {
    return tracer_.occluded(ray);
}

std::uint32_t Whitted::material_of(const Hit& hit) const {
    const Object& o = scene().objects[hit.object];
    if (o.mesh && !o.mesh->triangle_material.empty())
        return o.mesh->triangle_material[hit.primitive];
    return o.material;
}

bool Whitted::interpolated_normal(const Hit& hit, Vec3d& n) const {
    const Object& o = scene().objects[hit.object];
    if (!o.mesh)
        return false;
    std::array<Vec3d, 3> c;
    if (o.mesh->normals.size() == o.mesh->positions.size()) {
        const auto& t = o.mesh->triangles[hit.primitive];
        c = {Vec3d(o.mesh->normals[t[0]]), Vec3d(o.mesh->normals[t[1]]),
             Vec3d(o.mesh->normals[t[2]])};
    } else if (const CornerNormals* computed = computed_normals_[hit.object]) {
        const auto& k = computed->corners[hit.primitive];
        c = {Vec3d(computed->normals[k[0]]), Vec3d(computed->normals[k[1]]),
             Vec3d(computed->normals[k[2]])};
    } else {
        return false;
    }
    n = at_hit(hit, c[0], c[1], c[2]);
    return true;
}

Vec3d Whitted::shading_normal(const Hit& hit) const {
    Vec3d n;
    return interpolated_normal(hit, n) ? unit_or(n, hit.normal) : hit.normal;
}

std::optional<Vec3d> Whitted::texel(const Hit& hit, const Material& m) const {
    if (!m.texture)
        return std::nullopt;
    const Object& o = scene().objects[hit.object];
    if (!o.mesh || o.mesh->corner_uvs.size() != o.mesh->size())
        return std::nullopt;
    // The hit's barycentrics interpolate the corners' (u, v) as they do the shading normal.
    const auto& c = o.mesh->corner_uvs[hit.primitive];
    const double u = at_hit<double>(hit, c[0][0], c[1][0], c[2][0]);
    const double v = at_hit<double>(hit, c[0][1], c[1][1], c[2][1]);
    return m.texture->sample(u, v);
}

Vec3d Whitted::radiance(const Ray& ray, RayCounts& counts) const {
    ++counts.primary;
    return trace(ray, 1, counts, nullptr, nullptr);
}

Vec3d Whitted::shade_hit(const Ray& ray, const Hit& hit, RayCounts& counts) const {
    return shade(ray, hit, 1, counts, nullptr);
}

/// A ray tree being built, and the token that may stop it.
struct Whitted::TreeBuild {
    RayTree& out;
    const CancelToken& cancel;
};

Result<RayTree> Whitted::tree(const Ray& ray, const CancelToken& cancel) const {
    RayTree t;
    ++t.counts.primary;
    int root = -1;
    TreeBuild build{t, cancel};
    t.color = trace(ray, 1, t.counts, &build, &root);
    if (cancel.fired())
        return cancel.status();
    return t;
}

Vec3d Whitted::trace(const Ray& ray, int depth, RayCounts& counts, TreeBuild* tree,
                     int* slot) const {
    // Asked once per node: a tree can branch at every transparent and reflecting surface, up
    // to 2^max_depth nodes. Once it fires, no more nodes are added.
    if (tree && tree->cancel.cancelled())
        return options_.background;
    const std::optional<Hit> hit = closest(ray);
    if (!hit)
        return options_.background;
    if (tree)
        *slot = static_cast<int>(tree->out.nodes.size());
    return shade(ray, *hit, depth, counts, tree);
}

struct Whitted::Surface {
    const Hit& hit;
    const Material& m;
    std::uint32_t material;
    // The material's ambient and diffuse colours, and its specular colour's base-colour share,
    // times its texture's colour at the hit (its own where it has no texture). Held here rather
    // than in a textured copy of the Material: copying one per hit (144 bytes and an atomic count
    // on its texture's shared_ptr) had been a tenth of a Duck render's shading (perf,
    // bench_render).
    Vec3d ka;
    Vec3d kd;
    Vec3d ks;
    Vec3d d;          ///< unit direction of the incoming ray
    Vec3d p;          ///< the hit point
    Vec3d ng;         ///< geometric normal, turned to face the ray (spawned origins move along it)
    Vec3d n;          ///< shading normal, on the same side
    Vec3d p_err;      ///< error bound of p (shade/spawn.h)
    bool camera_hit;  ///< depth 1: the camera ray's own hit
    /// The robust origins of the rays leaving this point, each side's formed once (spawn.h).
    /// Mutable, and formed by const spawns: a Surface belongs to the thread that built it
    /// (shade()'s local, or shade_batch's leased buffers, which its loops walk one at a time).
    mutable SpawnOrigins origins{};

    /// offset_ray_origin(p, p_err, ng, w), bit for bit.
    Vec3d origin_towards(const Vec3d& w) const { return origins.towards(p, p_err, ng, w); }
};

Whitted::Surface Whitted::surface(const Ray& ray, const Hit& hit, int depth) const {
    const std::uint32_t mi = material_of(hit);
    const Material& m = scene().materials[mi];
    Vec3d ka = m.ambient, kd = m.diffuse, ks = m.specular;
    if (const std::optional<Vec3d> t = texel(hit, m)) {
        ka = m.ambient * *t;
        kd = m.diffuse * *t;
        // Only a metal's share of the specular colour is its base colour (Material).
        if (is_nonzero(m.textured_specular))
            ks = m.specular - m.textured_specular + m.textured_specular * *t;
    }
    const Vec3d d = normalize(ray.direction);
    // The sides are chosen before normalising: a positive factor leaves a dot product's sign as
    // it is (but where the product is within its rounding error of 0, a grazing hit with
    // |cos θ| below ~1e-15, where either side is as right), and the choices then do not wait
    // for the square roots and divisions of the normalisations, which had held up every hit
    // (rdtsc around surface()'s loop in shade_batch, the Duck, alternating pairs, 2026-12-07:
    // 7% less time without that wait on the direction, 3% less again on the shading normal).
    const Vec3d ng = face_towards_ray(hit.normal, ray.direction);
    Vec3d n = ng;
    if (Vec3d s; interpolated_normal(hit, s)) {
        if (dot(s, ng) < 0.0)
            s = -s;
        n = unit_or(s, ng);  // −s/|s| is −(s/|s|) bit for bit
    }
    // From afar (2²⁰ object sizes) the point is taken on the surface: o + t·d rounds by
    // u·|o|, which put a camera ray's hit from 2⁶⁶ away 8,192 units off its triangle and judged
    // a light in front of it to be behind (a helper's review; query/intersect.h, hit_point).
    Vec3d p, p_err;
    if (engine_.surface_point(ray, hit, p, p_err)) {
        p_err += float_tracer_error(p, tracer_.float_frame());
    } else {
        p = ray.at(hit.t);
        p_err = hit_point_error(ray, hit, tracer_.float_frame());
    }
    return Surface{hit, m, mi, ka, kd, ks, d, p, ng, n, p_err, depth == 1};
}

// Inline, as the in-place shadow_ray below: shade_batch calls both per light per hit. A point
// light's side is decided on the direction before it is normalised, as surface() decides its
// normals' sides, so that the choice, and the shadow ray's branch on it, do not wait for the
// square root and the divisions. The sign is the normalised direction's but for rounding where
// the product is within its error of 0 (a grazing light, whose terms then round to nothing
// either way), and where the products underflow (a light within ~1e-308 of the point). A
// direction with an infinite component (a light near double's range from the point) is not
// facing, as its normalised form, NaN, was not: such a shadow ray would not be a valid ray.
// The direction is normalised only where it is used, by direct() for a facing light whose
// shadow ray is free (unit_towards): the shadow ray needs only the light's position, and a
// light behind the surface, or one whose shadow ray is blocked, had its direction normalised
// for nothing.
inline Whitted::ToLight Whitted::towards_light(const Surface& sp, const Light& light,
                                               std::size_t k) const {
    ToLight t;
    if (light.type == LightType::point) {
        t.l = light.position - sp.p;
        t.facing = dot(sp.n, t.l) > 0.0 && is_finite(t.l);
    } else {
        t.l = plan_.towards_directional[k];
        t.facing = dot(sp.n, t.l) > 0.0;
    }
    return t;
}

inline void Whitted::shadow_ray(Ray& r, const Surface& sp, const Light& light,
                                const Vec3d& l) const {
    if (light.type == LightType::point) {
        // l is light.position − sp.p (towards_light), spawn_ray_to's own target − p.
        spawn_ray_to_from(r, sp.origin_towards(l), light.position);
    } else {
        spawn(r, sp, l);
    }
}

void Whitted::shade_hits(const std::vector<Ray>& rays, const std::vector<Hit>& hits,
                         std::vector<Vec3d>& out, RayCounts& counts) const {
    out.resize(rays.size());
    shade_hits(rays.data(), hits.data(), rays.size(), out.data(), counts);
}

void Whitted::shade_hits(const Ray* rays, const Hit* hits, std::size_t n, Vec3d* out,
                         RayCounts& counts) const {
    // A scene small enough for the tracer to scan itself traces ray by ray: batches exist for
    // Embree's packets, which a scan does not have (with the BVH the scan replaced, batches
    // had cost more than they saved there too: bench_render, tutorial_like at fast, 460 ms
    // batched against 215 ms ray by ray at spp 1), while the Duck's mesh gains 1.29–1.33×.
    if (!options_.trace_in_batches || tracer_.scans()) {
        for (std::size_t i = 0; i < n; ++i)
            out[i] = hits[i].valid() ? shade_hit(rays[i], hits[i], counts) : options_.background;
        return;
    }
    shade_batch(rays, hits, n, 1, out, counts);
}

/// shade_batch's buffers, leased for each batch (engine/thread_scratch.h): each keeps its size
/// from one batch to the next, and a batch writes its own elements over what is left there.
struct Whitted::BatchScratch {
    std::vector<Surface> surfaces;
    std::vector<std::size_t> hit_of;  // surfaces[h] is the hit of rays[hit_of[h]]
    std::vector<Ray> shadow;
    std::vector<std::size_t> slot;  // shadow[j] answers towards[slot[j]]
    std::vector<ToLight> towards;
    std::vector<std::uint8_t> blocked;
    std::vector<Vec3d> direct_color, indirect_color;
    std::vector<Ray> next[2];
    std::vector<std::size_t> owner[2];
    std::vector<Hit> next_hits;
    std::vector<Vec3d> next_color;

    std::size_t bytes() const {
        std::size_t b = capacity_bytes(surfaces) + capacity_bytes(hit_of) + capacity_bytes(shadow) +
                        capacity_bytes(slot) + capacity_bytes(towards) + capacity_bytes(blocked) +
                        capacity_bytes(direct_color) + capacity_bytes(indirect_color) +
                        capacity_bytes(next_hits) + capacity_bytes(next_color);
        for (int kind = 0; kind < 2; ++kind)
            b += capacity_bytes(next[kind]) + capacity_bytes(owner[kind]);
        return b;
    }
};

void Whitted::release_thread_scratch() {
    ThreadScratch<BatchScratch>::release_all();
}

std::size_t Whitted::thread_scratch_bytes() {
    return ThreadScratch<BatchScratch>::kept_bytes();
}

void Whitted::shade_batch(const Ray* rays, const Hit* hits, std::size_t n, int depth, Vec3d* out,
                          RayCounts& counts) const {
    ThreadScratch<BatchScratch> scratch;
    std::vector<Surface>& surfaces = scratch->surfaces;
    surfaces.clear();  // a Surface holds references: built anew in each batch
    surfaces.reserve(n);
    std::size_t* const hit_of = slots(scratch->hit_of, n);
    // Each Surface is built in its slot: emplace_back constructs the element from the prvalue
    // the conversion returns, which GCC and Clang elide into the slot (CWG 2327; the standard
    // does not promise it, and a copy would only cost time), where push_back(surface(...)) had
    // built 200 bytes on the stack and copied them in (perf annotate of shade_batch).
    struct InSlot {
        const Whitted& w;
        const Ray& ray;
        const Hit& hit;
        int depth;
        operator Surface() const { return w.surface(ray, hit, depth); }
    };
    for (std::size_t i = 0; i < n; ++i) {
        if (!hits[i].valid()) {
            out[i] = options_.background;
            continue;
        }
        hit_of[surfaces.size()] = i;
        surfaces.emplace_back(InSlot{*this, rays[i], hits[i], depth});
    }
    const std::size_t count = surfaces.size();
    // Shadow rays light by light, so that the rays of neighbouring hits to one light sit side
    // by side.
    const std::size_t lights = plan_.shadow_lights.size();
    // Sized for every surface and light, each ray written into its slot, and only the rays
    // traced handed on: emplace_back, which LTO left out of line, cost a call and a check a ray
    // (the shadow rays' loop took 6% less time, the secondary rays' 13%: rdtsc around each in
    // shade_batch, the Duck, four alternating pairs, 2026-12-07).
    Ray* const shadow = slots(scratch->shadow, count * lights);
    std::size_t* const slot = slots(scratch->slot, count * lights);
    std::size_t traced = 0;
    // Each surface's direction to each light, kept for direct() so that it is not computed
    // twice; towards_light() writes every field.
    ToLight* const towards = slots(scratch->towards, count * lights);
    for (std::size_t k = 0; k < lights; ++k) {
        const Light& light = scene().lights[plan_.shadow_lights[k]];
        for (std::size_t h = 0; h < count; ++h) {
            ToLight& t = towards[h * lights + k];
            t = towards_light(surfaces[h], light, k);
            if (t.facing) {
                shadow_ray(shadow[traced], surfaces[h], light, t.l);
                slot[traced++] = h * lights + k;
            }
        }
    }
    if (traced > 0) {
        std::uint8_t* const blocked = slots(scratch->blocked, traced);
        tracer_.occluded_batch(shadow, traced, blocked);
        counts.shadow += traced;
        for (std::size_t j = 0; j < traced; ++j)
            towards[slot[j]].blocked = blocked[j] != 0;
    }
    Vec3d* const direct_color = slots(scratch->direct_color, count);
    for (std::size_t h = 0; h < count; ++h) {
        bool lit = false;
        direct_color[h] =
            direct(surfaces[h], counts, nullptr, lit, lights ? &towards[h * lights] : nullptr);
    }
    // The next generation: every reflected ray of this one as a batch, then every refracted
    // ray, each shaded by the same function one level deeper. Summed in indirect()'s order
    // (reflection, then refraction, then onto the direct light), so that the colours are
    // shade_hit()'s to the last bit wherever the rays' answers are.
    Vec3d* indirect_color = nullptr;  // below max_depth only
    if (depth < options_.max_depth) {
        indirect_color = slots(scratch->indirect_color, count);
        std::fill(indirect_color, indirect_color + count, Vec3d{});
        // Written into their slots as the shadow rays are. Only a kind the plan traces is sized:
        // secondary_rays() gives a reflected ray only under plan_.reflection and a refracted
        // one only under plan_.refraction.
        Ray* next[2] = {nullptr, nullptr};
        std::size_t* owner[2] = {nullptr, nullptr};
        std::size_t spawned[2] = {0, 0};
        const bool kinds[2] = {plan_.reflection, plan_.refraction};
        for (int kind = 0; kind < 2; ++kind) {
            if (kinds[kind]) {
                next[kind] = slots(scratch->next[kind], count);
                owner[kind] = slots(scratch->owner[kind], count);
            }
        }
        for (std::size_t h = 0; h < count; ++h) {
            const SecondaryRays sec = secondary_rays(surfaces[h]);
            if (sec.reflected) {
                spawn(next[0][spawned[0]], surfaces[h], *sec.reflected);
                owner[0][spawned[0]++] = h;
            }
            if (sec.refracted) {
                spawn(next[1][spawned[1]], surfaces[h], *sec.refracted);
                owner[1][spawned[1]++] = h;
            }
        }
        counts.reflected += spawned[0];
        counts.refracted += spawned[1];
        for (int kind = 0; kind < 2; ++kind) {
            const std::size_t m = spawned[kind];
            if (m == 0)
                continue;
            Hit* const next_hits = slots(scratch->next_hits, m);
            tracer_.closest_batch(next[kind], m, next_hits);
            Vec3d* const next_color = slots(scratch->next_color, m);
            shade_batch(next[kind], next_hits, m, depth + 1, next_color, counts);
            for (std::size_t j = 0; j < m; ++j) {
                const Material& mat = surfaces[owner[kind][j]].m;
                indirect_color[owner[kind][j]] +=
                    next_color[j] * (kind == 0 ? mat.reflectivity : mat.transparency);
            }
        }
    }
    for (std::size_t h = 0; h < count; ++h)
        out[hit_of[h]] = indirect_color ? direct_color[h] + indirect_color[h] : direct_color[h];
}

Vec3d Whitted::shade(const Ray& ray, const Hit& hit, int depth, RayCounts& counts,
                     TreeBuild* tree) const {
    const Surface sp = surface(ray, hit, depth);

    // Node k of the tree is written before its children so that labels run depth-first; the
    // vector may grow during the recursion, so the node is addressed by index, never by reference.
    const std::size_t k = tree ? tree->out.nodes.size() : 0;
    if (tree) {
        TreeNode node;
        node.hit = hit;
        node.point = sp.p;
        node.normal = sp.n;
        tree->out.nodes.push_back(std::move(node));
    }
    bool lit = false;
    // direct() does not recurse, so the node's address is stable while it runs.
    Vec3d color = direct(sp, counts, tree ? &tree->out.nodes[k] : nullptr, lit);
    if (depth < options_.max_depth)
        color += indirect(sp, depth, counts, tree, k);
    if (tree) {
        tree->out.nodes[k].full_phong = lit;
        tree->out.nodes[k].color = color;
    }
    return color;
}

Ray Whitted::shadow_ray(const Surface& sp, const Light& light, const Vec3d& l) const {
    Ray r;
    shadow_ray(r, sp, light, l);
    return r;
}

// Inline, defined before direct(), its caller per light per hit: out of line, its 24-byte
// answer came back through memory, and direct()'s loop took 18% less time inline (rdtsc around
// that loop in shade_batch, a Duck render, three alternating pairs, 2026-12-07).
inline Vec3d Whitted::lit_by(const Surface& sp, const Vec3d& l, const Vec3d& intensity) const {
    return phong_light(sp.kd, sp.ks, sp.m.shininess, sp.n, l, -sp.d, intensity,
                       plan_.specular[sp.material])
        .sum();
}

Vec3d Whitted::direct(const Surface& sp, RayCounts& counts, TreeNode* node, bool& lit,
                      const ToLight* traced) const {
    const Scene& s = scene();
    Vec3d color = sp.m.emissive + phong_ambient(sp.ka, plan_.ambient);
    for (std::size_t k = 0; k < plan_.shadow_lights.size(); ++k) {
        const std::uint32_t li = plan_.shadow_lights[k];
        const Light& light = s.lights[li];
        const ToLight t = traced ? traced[k] : towards_light(sp, light, k);
        const Vec3d& l = t.l;  // unnormalised for a point light: unit_towards() below
        ShadowRayRecord rec;
        rec.light = li;
        rec.facing = t.facing;
        if (rec.facing) {
            bool blocked;
            if (traced) {
                blocked = t.blocked;
            } else if (node) {
                ++counts.shadow;
                // The tree names the blocker, so it asks for the closest one.
                const std::optional<Hit> b = closest(shadow_ray(sp, light, l));
                blocked = b.has_value();
                if (b)
                    rec.blocked_by = b->object;
            } else {
                ++counts.shadow;
                blocked = occluded(shadow_ray(sp, light, l));
            }
            if (!blocked) {
                lit = true;
                color += lit_by(sp, unit_towards(t, light), light.intensity);
            }
        }
        if (node)
            node->shadow_rays.push_back(rec);
    }
    if (plan_.headlight)
        color += headlight_terms(sp, counts, lit);
    return color;
}

Vec3d Whitted::headlight_terms(const Surface& sp, RayCounts& counts, bool& lit) const {
    const Light& h = *plan_.headlight;
    const Vec3d l = -h.direction;
    if (!(dot(sp.n, l) > 0.0))
        return {};
    // A camera hit is the closest point along the eye's ray, and the light comes from the eye's
    // side, so it counts as lit without a ray (docs/api.md). Strictly that holds for the ray
    // along the view direction; off-axis rays differ from it by at most half the field of view,
    // and a preview takes that approximation for a shadow ray less per pixel.
    if (!sp.camera_hit) {
        ++counts.shadow;
        if (occluded(spawn(sp, l)))
            return {};
    }
    lit = true;
    return lit_by(sp, l, h.intensity);
}

Whitted::SecondaryRays Whitted::secondary_rays(const Surface& sp) const {
    SecondaryRays out;
    // Leaving a transparent object: its internal reflection is not traced (the tutorial).
    const bool leaving_glass = sp.m.transparency > 0.0 && !sp.hit.front_face;
    if (plan_.reflection && sp.m.reflectivity > 0.0 && !leaving_glass)
        out.reflected = reflect(sp.d, sp.n);
    if (plan_.refraction && sp.m.transparency > 0.0) {
        const double eta = sp.hit.front_face ? 1.0 / sp.m.ior : sp.m.ior;
        if (const std::optional<Vec3d> t = refract(sp.d, sp.n, eta)) {
            out.refracted = *t;
        } else {
            out.total_internal_reflection = true;
        }
    }
    return out;
}

Ray Whitted::spawn(const Surface& sp, const Vec3d& w) {
    Ray r;
    spawn(r, sp, w);
    return r;
}

// spawn_ray(r, sp.p, sp.p_err, sp.ng, w), with the surface's origin for w's side.
void Whitted::spawn(Ray& r, const Surface& sp, const Vec3d& w) {
    spawn_ray_from(r, sp.origin_towards(w), w);
}

Vec3d Whitted::indirect(const Surface& sp, int depth, RayCounts& counts, TreeBuild* tree,
                        std::size_t k) const {
    Vec3d color;
    const SecondaryRays sec = secondary_rays(sp);
    if (sec.reflected) {
        ++counts.reflected;
        int child = -1;
        color +=
            trace(spawn(sp, *sec.reflected), depth + 1, counts, tree, &child) * sp.m.reflectivity;
        if (tree)
            tree->out.nodes[k].reflected = child;
    }
    if (sec.refracted) {
        ++counts.refracted;
        int child = -1;
        color +=
            trace(spawn(sp, *sec.refracted), depth + 1, counts, tree, &child) * sp.m.transparency;
        if (tree)
            tree->out.nodes[k].refracted = child;
    } else if (sec.total_internal_reflection && tree) {
        tree->out.nodes[k].total_internal_reflection = true;
    }
    return color;
}

}  // namespace raycastd::engine
