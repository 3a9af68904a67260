#pragma once
// Image: a linear RGB float image, and its encodings.
//
//   png  8-bit sRGB (IEC 61966-2-1 transfer curve), written by png.h with zlib
//   ppm  binary P6, 8-bit sRGB (Netpbm's PPM holds gamma-encoded samples)
//   pfm  Portable Float Map, linear 32-bit floats, bottom row first (Netpbm/Debevec's PF)
//   exr  OpenEXR 2.0 single-part scanline file, uncompressed, linear 32-bit float R, G, B
//        (written from the OpenEXR file layout specification; no library needed)
//
// `linear_8bit = true` skips the sRGB curve for the 8-bit formats: the data shading modes
// (normal, depth, object_id, barycentric) store values, not light.

#include <cstddef>
#include <memory>
#include <new>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "engine/math/vec3.h"

namespace raycastd::engine {

/// std::allocator, except that a value made without arguments is default-initialised: a float
/// is left as it is, so a large buffer is not written before it is used.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
    template <class U>
    struct rebind {
        using other = DefaultInitAllocator<U>;
    };
    DefaultInitAllocator() = default;
    template <class U>
    DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}  // NOLINT: as std::allocator
    template <class U>
    void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
        ::new (static_cast<void*>(p)) U;
    }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};

struct Image {
    /// Pixels that Image(w, h, Fill::unset) leaves unwritten: zero-filling a 4096² render's
    /// 192 MB first cost ~1 s of page faults on a loaded 2-core machine before the first tile
    /// (during which the render could not be cancelled); its tiles write every pixel instead.
    using Pixels = std::vector<float, DefaultInitAllocator<float>>;
    /// What a new image's pixels hold.
    enum class Fill { black, unset };

    int width = 0;
    int height = 0;
    Pixels rgb;  ///< row-major from the top row, 3 floats per pixel

    Image() = default;
    /// A w × h image, black (or, with Fill::unset, with indeterminate pixels every one of which
    /// the caller writes: a render's tiles).
    Image(int w, int h, Fill fill = Fill::black) : width(w), height(h) {
        const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3;
        if (fill == Fill::black) {
            rgb.assign(n, 0.0f);
        } else {
            rgb.resize(n);
        }
    }
    void set(int x, int y, const Vec3d& c) {
        float* p = &rgb[3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                             static_cast<std::size_t>(x))];
        p[0] = static_cast<float>(c.x);
        p[1] = static_cast<float>(c.y);
        p[2] = static_cast<float>(c.z);
    }
    Vec3d at(int x, int y) const {
        const float* p = &rgb[3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                                   static_cast<std::size_t>(x))];
        return {p[0], p[1], p[2]};
    }
};

enum class ImageFormat { png, ppm, pfm, exr };

/// "png", "ppm", "pfm", "exr" → the format; nullopt for anything else.
std::optional<ImageFormat> image_format_from_name(std::string_view name);
/// The MIME type of an encoded image ("image/png", "image/x-portable-pixmap", ...).
const char* mime_type(ImageFormat format);

/// The sRGB encoding of a linear value in [0, 1] (clamped; NaN: 0), as an 8-bit code: the IEC
/// 61966-2-1 curve, rounded to nearest.
unsigned char srgb_encode(float linear);
/// The same code computed by the curve's formula in float (srgb_encode reads it from a table built
/// with this, and equals it on every float).
unsigned char srgb_encode_formula(float linear);
/// The 8-bit code a value is written as: sRGB-encoded, or with `linear` (the data modes) the
/// value in [0, 1] (clamped; not finite: 0) times 255, rounded.
unsigned char encode_8bit(float value, bool linear);
/// encode_8bit of values[0, n) into out[0, n).
void encode_8bit(const float* values, std::size_t n, bool linear, unsigned char* out);

/// The image encoded in `format`. Never fails for a well-formed Image (width·height·3 floats).
std::string encode_image(const Image& image, ImageFormat format, bool linear_8bit = false);

}  // namespace raycastd::engine
