#pragma once
// Base-colour textures: a decoded image and how it is sampled (glTF 2.0 §3.8.4 samplers; OBJ
// map_Kd). Shared read-only by every render of a scene.
//
// Texture coordinates follow glTF (§3.8.4.1): (0, 0) is the first texel of the image's first
// row (its top-left corner), u runs along the row and v down the rows; a loader converts its
// format's convention to this one (OBJ's v runs up: v ↦ 1 − v).

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "engine/math/vec3.h"

namespace raycastd::engine {

/// 8-bit sRGB-encoded RGB texels, rows top to bottom (as PNG and JPEG store them).
struct TextureImage {
    int width = 0;
    int height = 0;
    std::vector<std::uint8_t> rgb;  ///< width · height · 3 bytes

    std::size_t memory_bytes() const { return rgb.capacity() + sizeof(*this); }
};

/// glTF sampler wrap modes (§5.26: 33071 CLAMP_TO_EDGE, 33648 MIRRORED_REPEAT, 10497 REPEAT).
enum class TextureWrap { repeat, clamp_to_edge, mirrored_repeat };

struct Texture {
    std::shared_ptr<const TextureImage> image;
    TextureWrap wrap_s = TextureWrap::repeat;  ///< along u
    TextureWrap wrap_t = TextureWrap::repeat;  ///< along v
    bool nearest = false;                      ///< magFilter NEAREST; else bilinear

    /// The linear-light RGB colour at (u, v): texels are decoded from sRGB (IEC 61966-2-1)
    /// before they are filtered, so blending happens in linear light. Bilinear between the
    /// four texel centres around (u·width − ½, v·height − ½), each index wrapped by its
    /// mode. Minification is not filtered (no mipmaps): a texel per sample, which spp > 1
    /// averages. Non-finite coordinates sample (0, 0).
    Vec3d sample(double u, double v) const;
};

/// The linear value of an 8-bit sRGB code (IEC 61966-2-1 §5.2: c/12.92 up to 0.04045,
/// else ((c + 0.055)/1.055)^2.4), from a table computed once.
double srgb_to_linear(std::uint8_t code);

}  // namespace raycastd::engine
