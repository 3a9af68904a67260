// glTF scene objects mapped to the engine's: node transforms, materials, cameras and
// KHR_lights_punctual lights.

#include <algorithm>
#include <cmath>

#include "engine/load/gltf_internal.h"

namespace raycastd::engine::gltf {

namespace {

constexpr double kPi = 3.14159265358979323846;

Status fail(std::string msg) {
    return Status::error(Code::model_load_failed, std::move(msg));
}

bool all_finite(const std::vector<double>& v) {
    return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

double clamp01(double v) {
    return std::isfinite(v) ? std::clamp(v, 0.0, 1.0) : 0.0;
}

}  // namespace

Result<Transform> local_transform(const tinygltf::Node& node, int index) {
    const std::string where = "/nodes/" + std::to_string(index);
    if (!node.matrix.empty()) {
        if (node.matrix.size() != 16 || !all_finite(node.matrix)) {
            return fail(where + "/matrix must be 16 finite numbers");
        }
        std::array<double, 16> m{};
        std::copy(node.matrix.begin(), node.matrix.end(), m.begin());
        return Transform::from_column_major(m);
    }
    if ((!node.translation.empty() && node.translation.size() != 3) ||
        (!node.rotation.empty() && node.rotation.size() != 4) ||
        (!node.scale.empty() && node.scale.size() != 3) || !all_finite(node.translation) ||
        !all_finite(node.rotation) || !all_finite(node.scale)) {
        return fail(where + ": translation/scale must be 3 and rotation 4 finite numbers");
    }
    Vec3d t{0, 0, 0}, s{1, 1, 1};
    std::array<double, 4> q{0, 0, 0, 1};
    if (!node.translation.empty())
        t = {node.translation[0], node.translation[1], node.translation[2]};
    if (!node.scale.empty())
        s = {node.scale[0], node.scale[1], node.scale[2]};
    if (!node.rotation.empty())
        q = {node.rotation[0], node.rotation[1], node.rotation[2], node.rotation[3]};
    return Transform::from_trs(t, q, s);
}

// Metallic-roughness → Phong. glTF 2.0 Appendix B (BRDF implementation) gives the specular
// reflectance at normal incidence as F0 = mix(0.04, baseColor, metallic) and the microfacet
// roughness as α = roughness². Walter et al., "Microfacet Models for Refraction through Rough
// Surfaces" (EGSR 2007) eq. 33 relates a Beckmann α to the Phong exponent that gives the same
// highlight width: n = 2/α² − 2, i.e. n = 2/roughness⁴ − 2. The same appendix gives the
// diffuse colour as c_diff = mix(baseColor, black, metallic): a metal has none, its colour is
// all in F0. Hence:
//   diffuse   = baseColor.rgb · (1 − metallic)
//   ambient   = 0.1 · baseColor.rgb       (the engine's ambient-to-diffuse ratio, of the base
//                                          colour: a metal's indirect light is its reflection)
//   specular  = mix(0.04, baseColor.rgb, metallic)
//   shininess = clamp(2/roughness⁴ − 2, 1, 1000)
// and the baseColorTexture at a hit multiplies the diffuse, the ambient and the specular's
// baseColor·metallic share (Material::textured_specular; shade/whitted.cpp). Until 2026-12-05
// the diffuse was the whole base colour at every metallic: glTF's default material (metallic 1,
// roughness 1) then had its base colour twice, as diffuse and as a shininess-1 specular lobe,
// and a textured Cube.gltf seen head-on under the headlight came out white (a helper's review).
// A metallicRoughnessTexture is not sampled per hit: its mean multiplies the factors.
//   emissive  = emissiveFactor (× KHR_materials_emissive_strength)
//   transparency = 1 − baseColor.a for alphaMode BLEND (alpha blending seen as see-through)
// Defaults are glTF's (§5.22): baseColor 1, metallic 1, roughness 1.
Material to_phong(const tinygltf::Material& m,
                  const std::optional<std::array<double, 2>>& metallic_roughness) {
    const auto& pbr = m.pbrMetallicRoughness;
    std::array<double, 4> base{1, 1, 1, 1};
    if (pbr.baseColorFactor.size() == 4) {
        for (std::size_t i = 0; i < 4; ++i)
            base[i] = clamp01(pbr.baseColorFactor[i]);
    }
    // The factors times the metallicRoughnessTexture's mean, where it has one
    // (metallic_roughness_means).
    const double metallic =
        clamp01(pbr.metallicFactor) * (metallic_roughness ? (*metallic_roughness)[0] : 1.0);
    const double roughness =
        clamp01(pbr.roughnessFactor) * (metallic_roughness ? (*metallic_roughness)[1] : 1.0);
    Material out;
    const Vec3d base_rgb{base[0], base[1], base[2]};
    out.diffuse = base_rgb * (1.0 - metallic);
    out.ambient = base_rgb * 0.1;
    out.textured_specular = base_rgb * metallic;
    out.specular = Vec3d{0.04, 0.04, 0.04} * (1.0 - metallic) + out.textured_specular;
    const double r4 = roughness * roughness * roughness * roughness;
    out.shininess = r4 > 0.0 ? std::clamp(2.0 / r4 - 2.0, 1.0, 1000.0) : 1000.0;
    double emissive_strength = 1.0;
    if (auto it = m.extensions.find("KHR_materials_emissive_strength");
        it != m.extensions.end() && it->second.IsObject() && it->second.Has("emissiveStrength")) {
        const auto& v = it->second.Get("emissiveStrength");
        if (v.IsNumber() && std::isfinite(v.GetNumberAsDouble()) && v.GetNumberAsDouble() >= 0) {
            emissive_strength = v.GetNumberAsDouble();
        }
    }
    // The factor multiplies the emissiveTexture (§3.9.3), which is not read: alone it would
    // make the whole surface glow at the factor (MultiUVTest.gltf, factor 1 over a pattern,
    // came out white). Left out; build_model says so in a warning.
    if (m.emissiveFactor.size() == 3 && m.emissiveTexture.index < 0) {
        out.emissive = Vec3d{clamp01(m.emissiveFactor[0]), clamp01(m.emissiveFactor[1]),
                             clamp01(m.emissiveFactor[2])} *
                       emissive_strength;
    }
    if (m.alphaMode == "BLEND")
        out.transparency = 1.0 - base[3];
    return out;
}

// glTF 2.0 §3.10.1: "the camera is defined such that the local +X axis is to the right, the
// lens looks towards the local −Z axis, and the top of the camera is aligned with the local +Y
// axis"; `yfov` is the vertical field of view in radians (§5.14).
std::optional<Camera> to_camera(const tinygltf::Camera& camera, const Transform& world) {
    if (camera.type != "perspective")
        return std::nullopt;
    const double yfov = camera.perspective.yfov;
    if (!std::isfinite(yfov) || yfov <= 0.0 || yfov >= kPi)
        return std::nullopt;
    const Vec3d forward = normalize(world.apply_vector({0, 0, -1}));
    const Vec3d up = normalize(world.apply_vector({0, 1, 0}));
    if (length(forward) == 0.0 || length(up) == 0.0)
        return std::nullopt;
    Camera c;
    c.position = world.apply_point({0, 0, 0});
    c.look_at = c.position + forward;
    c.up = up;
    c.fov_y_deg = yfov * 180.0 / kPi;
    return c;
}

Result<int> node_light(const tinygltf::Node& node, int index, std::size_t light_count) {
    auto it = node.extensions.find("KHR_lights_punctual");
    if (it == node.extensions.end())
        return -1;
    const std::string where =
        "/nodes/" + std::to_string(index) + "/extensions/KHR_lights_punctual/light";
    if (!it->second.IsObject() || !it->second.Has("light") || !it->second.Get("light").IsNumber()) {
        return fail(where + " must be a light index");
    }
    const double d = it->second.Get("light").GetNumberAsDouble();
    if (!(d >= 0.0) || d != std::floor(d) || d >= static_cast<double>(light_count)) {
        return fail(where + " refers to light " + std::to_string(d) + ", but the file defines " +
                    std::to_string(light_count));
    }
    return static_cast<int>(d);
}

// KHR_lights_punctual: point lights sit at the node's origin; directional and spot lights shine
// along the node's local −Z. The light's radiometric colour is color × intensity (candela for
// point and spot, lux for directional). Our Phong lights have no distance falloff, so those
// units cannot carry over; we keep hue and the lights' relative strengths and rescale them all
// together afterwards (normalize_light_intensities). A spot light's cone is not modelled: it
// becomes a point light, with a warning.
std::optional<Light> to_light(const tinygltf::Light& light, const Transform& world,
                              std::vector<std::string>& warnings) {
    Vec3d color{1, 1, 1};
    if (light.color.size() == 3 && all_finite(light.color)) {
        color = {std::max(light.color[0], 0.0), std::max(light.color[1], 0.0),
                 std::max(light.color[2], 0.0)};
    }
    const double intensity =
        std::isfinite(light.intensity) && light.intensity > 0.0 ? light.intensity : 0.0;
    Light out;
    out.intensity = color * intensity;
    const std::string label = light.name.empty() ? light.type + " light" : "'" + light.name + "'";
    if (light.type == "point" || light.type == "spot") {
        out.type = LightType::point;
        out.position = world.apply_point({0, 0, 0});
        if (light.type == "spot") {
            warnings.push_back("spot light " + label + " treated as a point light (cone ignored)");
        }
    } else if (light.type == "directional") {
        out.type = LightType::directional;
        out.direction = normalize(world.apply_vector({0, 0, -1}));
        if (length(out.direction) == 0.0) {
            warnings.push_back("directional light " + label +
                               " has a degenerate direction; skipped");
            return std::nullopt;
        }
    } else {
        warnings.push_back("light " + label + " of unknown type '" + light.type + "' skipped");
        return std::nullopt;
    }
    if (!is_finite(out.position) || !is_finite(out.intensity))
        return std::nullopt;
    return out;
}

void normalize_light_intensities(std::vector<Light>& lights) {
    double peak = 0.0;
    for (const Light& l : lights)
        peak = std::max(peak, max_component(l.intensity));
    if (peak <= 1.0)
        return;
    for (Light& l : lights)
        l.intensity = l.intensity / peak;
}

}  // namespace raycastd::engine::gltf
