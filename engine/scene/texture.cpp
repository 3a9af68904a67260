#include "engine/scene/texture.h"

#include <algorithm>
#include <cmath>

namespace raycastd::engine {

namespace {

std::array<double, 256> make_srgb_table() {
    std::array<double, 256> t{};
    for (std::size_t i = 0; i < t.size(); ++i) {
        const double c = static_cast<double>(i) / 255.0;
        t[i] = c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
    }
    return t;
}

/// The coordinate reduced to one period of its wrap mode, so that the texel indices computed
/// from it stay small whatever the coordinate: [0, 1) for repeat, [0, 2) for mirrored repeat
/// (the image, then its mirror), [0, 1] for clamp.
double reduce(double c, TextureWrap wrap) {
    if (!std::isfinite(c))
        return 0.0;
    switch (wrap) {
        case TextureWrap::repeat:
            return c - std::floor(c);
        case TextureWrap::mirrored_repeat:
            return c - 2.0 * std::floor(c / 2.0);
        case TextureWrap::clamp_to_edge:
            break;
    }
    return std::clamp(c, 0.0, 1.0);
}

/// Texel index i (possibly one outside the period) mapped into [0, n).
int wrap_index(long i, int n, TextureWrap wrap) {
    const long size = n;
    // Every mode leaves an index inside the image as it is: the four texels of a bilinear
    // sample almost always are, and the divisions below had been most of a sample's cost.
    if (i >= 0 && i < size)
        return static_cast<int>(i);
    switch (wrap) {
        case TextureWrap::repeat:
            return static_cast<int>(((i % size) + size) % size);
        case TextureWrap::mirrored_repeat: {
            const long m = ((i % (2 * size)) + 2 * size) % (2 * size);
            return static_cast<int>(m < size ? m : 2 * size - 1 - m);
        }
        case TextureWrap::clamp_to_edge:
            break;
    }
    return static_cast<int>(std::clamp(i, 0L, size - 1));
}

}  // namespace

namespace {

const std::array<double, 256>& srgb_table() {
    static const std::array<double, 256> table = make_srgb_table();
    return table;
}

}  // namespace

double srgb_to_linear(std::uint8_t code) {
    return srgb_table()[code];
}

Vec3d Texture::sample(double u, double v) const {
    if (!image || image->width <= 0 || image->height <= 0)
        return {1.0, 1.0, 1.0};
    const TextureImage& img = *image;
    const std::array<double, 256>& linear = srgb_table();  // srgb_to_linear(), fetched once
    auto texel = [&](int x, int y) {
        const std::size_t at = (static_cast<std::size_t>(y) * static_cast<std::size_t>(img.width) +
                                static_cast<std::size_t>(x)) *
                               3;
        return Vec3d{linear[img.rgb[at]], linear[img.rgb[at + 1]], linear[img.rgb[at + 2]]};
    };
    const double x = reduce(u, wrap_s) * img.width - 0.5;
    const double y = reduce(v, wrap_t) * img.height - 0.5;
    if (nearest) {
        const auto xi = static_cast<long>(std::floor(x + 0.5));
        const auto yi = static_cast<long>(std::floor(y + 0.5));
        return texel(wrap_index(xi, img.width, wrap_s), wrap_index(yi, img.height, wrap_t));
    }
    const double fx = std::floor(x), fy = std::floor(y);
    const double ax = x - fx, ay = y - fy;
    const auto x0 = static_cast<long>(fx), y0 = static_cast<long>(fy);
    const int xa = wrap_index(x0, img.width, wrap_s), xb = wrap_index(x0 + 1, img.width, wrap_s);
    const int ya = wrap_index(y0, img.height, wrap_t), yb = wrap_index(y0 + 1, img.height, wrap_t);
    const Vec3d top = texel(xa, ya) * (1.0 - ax) + texel(xb, ya) * ax;
    const Vec3d bottom = texel(xa, yb) * (1.0 - ax) + texel(xb, yb) * ax;
    return top * (1.0 - ay) + bottom * ay;
}

}  // namespace raycastd::engine
