#pragma once
// Phong material (Phong 1975) with the Whitted extensions: reflectivity and transparency with an
// index of refraction (Whitted 1980).

#include <memory>

#include "engine/math/vec3.h"
#include "engine/scene/texture.h"

namespace raycastd::engine {

struct Material {
    Vec3d ambient{0.1, 0.1, 0.1};
    Vec3d diffuse{0.7, 0.7, 0.7};
    Vec3d specular{0.2, 0.2, 0.2};
    double shininess = 32.0;
    double reflectivity = 0.0;  ///< weight of the mirror-reflected ray, 0..1
    double transparency = 0.0;  ///< weight of the refracted ray, 0..1
    double ior = 1.0;           ///< index of refraction (Snell's law)
    Vec3d emissive{0.0, 0.0, 0.0};
    /// Base-colour texture (glTF baseColorTexture, OBJ map_Kd): where a mesh has texture
    /// coordinates, its colour multiplies diffuse and ambient (docs/api.md, render), and
    /// `textured_specular`'s share of the specular colour. Null: none.
    std::shared_ptr<const Texture> texture;
    /// The part of `specular` that is the base colour, which the texture multiplies too: a
    /// metal's reflectance is its base colour (glTF 2.0 Appendix B, F0 = mix(0.04, baseColor,
    /// metallic): the share baseColor·metallic). Zero for every other source of materials.
    Vec3d textured_specular{0.0, 0.0, 0.0};
};

}  // namespace raycastd::engine
