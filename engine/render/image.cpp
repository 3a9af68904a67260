#include "engine/render/image.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include <stb_image_write.h>

namespace raycastd::engine {

namespace {

std::vector<unsigned char> to_8bit(const Image& img, bool linear) {
    std::vector<unsigned char> out(img.rgb.size());
    for (std::size_t i = 0; i < img.rgb.size(); ++i)
        out[i] = encode_8bit(img.rgb[i], linear);
    return out;
}

void append_png(void* context, void* data, int size) {
    auto* out = static_cast<std::string*>(context);
    out->append(static_cast<const char*>(data), static_cast<std::size_t>(size));
}

template <class T>
void put(std::string& out, T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));  // the engine runs on little-endian x86-64, as EXR is
    out.append(b, sizeof(T));
}

void put_attribute(std::string& out, const char* name, const char* type, std::int32_t size) {
    out.append(name).push_back('\0');
    out.append(type).push_back('\0');
    put<std::int32_t>(out, size);
}

// OpenEXR file layout: magic 20000630, version 2 (single-part scanline), the header's required
// attributes, one offset per chunk (one scanline per chunk without compression), then each
// chunk as y, byte count, and the scanline's channels in alphabetical order (B, G, R).
std::string encode_exr(const Image& img) {
    std::string out;
    put<std::int32_t>(out, 20000630);
    put<std::int32_t>(out, 2);
    put_attribute(out, "channels", "chlist", 3 * (2 + 16) + 1);
    for (const char* c : {"B", "G", "R"}) {
        out.append(c).push_back('\0');
        put<std::int32_t>(out, 2);  // FLOAT
        put<std::int32_t>(out, 0);  // pLinear and three reserved bytes
        put<std::int32_t>(out, 1);  // xSampling
        put<std::int32_t>(out, 1);  // ySampling
    }
    out.push_back('\0');
    put_attribute(out, "compression", "compression", 1);
    out.push_back('\0');  // NO_COMPRESSION
    for (const char* window : {"dataWindow", "displayWindow"}) {
        put_attribute(out, window, "box2i", 16);
        put<std::int32_t>(out, 0);
        put<std::int32_t>(out, 0);
        put<std::int32_t>(out, img.width - 1);
        put<std::int32_t>(out, img.height - 1);
    }
    put_attribute(out, "lineOrder", "lineOrder", 1);
    out.push_back('\0');  // INCREASING_Y
    put_attribute(out, "pixelAspectRatio", "float", 4);
    put<float>(out, 1.0f);
    put_attribute(out, "screenWindowCenter", "v2f", 8);
    put<float>(out, 0.0f);
    put<float>(out, 0.0f);
    put_attribute(out, "screenWindowWidth", "float", 4);
    put<float>(out, 1.0f);
    out.push_back('\0');  // end of header

    const auto w = static_cast<std::size_t>(img.width);
    const std::size_t line_bytes = 3 * w * sizeof(float);
    const std::uint64_t table_end = out.size() + 8 * static_cast<std::size_t>(img.height);
    for (int y = 0; y < img.height; ++y) {
        put<std::uint64_t>(out, table_end + static_cast<std::uint64_t>(y) * (8 + line_bytes));
    }
    for (int y = 0; y < img.height; ++y) {
        put<std::int32_t>(out, y);
        put<std::int32_t>(out, static_cast<std::int32_t>(line_bytes));
        const float* row = &img.rgb[3 * w * static_cast<std::size_t>(y)];
        for (int c : {2, 1, 0}) {
            for (std::size_t x = 0; x < w; ++x)
                put<float>(out, row[3 * x + static_cast<std::size_t>(c)]);
        }
    }
    return out;
}

// Portable Float Map: "PF\n<w> <h>\n-1.0\n" (negative scale: little-endian), rows bottom-up.
std::string encode_pfm(const Image& img) {
    std::string out =
        "PF\n" + std::to_string(img.width) + " " + std::to_string(img.height) + "\n-1.0\n";
    const std::size_t row = 3 * static_cast<std::size_t>(img.width) * sizeof(float);
    for (int y = img.height - 1; y >= 0; --y) {
        out.append(reinterpret_cast<const char*>(
                       &img.rgb[row / sizeof(float) * static_cast<std::size_t>(y)]),
                   row);
    }
    return out;
}

}  // namespace

std::optional<ImageFormat> image_format_from_name(std::string_view name) {
    if (name == "png")
        return ImageFormat::png;
    if (name == "ppm")
        return ImageFormat::ppm;
    if (name == "pfm")
        return ImageFormat::pfm;
    if (name == "exr")
        return ImageFormat::exr;
    return std::nullopt;
}

const char* mime_type(ImageFormat format) {
    switch (format) {
        case ImageFormat::png:
            return "image/png";
        case ImageFormat::ppm:
            return "image/x-portable-pixmap";
        case ImageFormat::pfm:
            return "image/x-portable-floatmap";
        case ImageFormat::exr:
            return "image/x-exr";
    }
    return "application/octet-stream";
}

unsigned char srgb_encode(float linear) {
    if (!(linear > 0.0f))
        return 0;  // also NaN
    if (linear >= 1.0f)
        return 255;
    // IEC 61966-2-1: 12.92·c below 0.0031308, else 1.055·c^(1/2.4) − 0.055.
    const float s =
        linear <= 0.0031308f ? 12.92f * linear : 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
    return static_cast<unsigned char>(std::lround(s * 255.0f));
}

unsigned char encode_8bit(float value, bool linear) {
    if (!linear)
        return srgb_encode(value);
    const float c = std::isfinite(value) ? std::clamp(value, 0.0f, 1.0f) : 0.0f;
    return static_cast<unsigned char>(std::lround(c * 255.0f));
}

namespace {

/// stb_image_write's defaults (deflate level 8, and each row tried with all five PNG filters to
/// keep the smallest) made the encode a fifth of a 640×480 Duck preview's time. The Sub filter
/// (PNG spec §9.2, type 1) on every row at level 5 encoded the same preview 1.6–2.0× faster for
/// 4% more bytes (10 encodes of each setting on this 2-core machine, docs/rendering.md; every
/// render reports its own encode time in X-Render-Breakdown).
/// The two are process-wide variables of libstb, set once, before the first encode reads them.
void set_png_encoder_options() {
    static const bool once = [] {
        stbi_write_png_compression_level = 5;
        stbi_write_force_png_filter = 1;
        return true;
    }();
    (void)once;
}

}  // namespace

std::string encode_image(const Image& img, ImageFormat format, bool linear_8bit) {
    switch (format) {
        case ImageFormat::png: {
            set_png_encoder_options();
            const std::vector<unsigned char> px = to_8bit(img, linear_8bit);
            std::string out;
            stbi_write_png_to_func(append_png, &out, img.width, img.height, 3, px.data(),
                                   img.width * 3);
            return out;
        }
        case ImageFormat::ppm: {
            const std::vector<unsigned char> px = to_8bit(img, linear_8bit);
            std::string out =
                "P6\n" + std::to_string(img.width) + " " + std::to_string(img.height) + "\n255\n";
            out.append(reinterpret_cast<const char*>(px.data()), px.size());
            return out;
        }
        case ImageFormat::pfm:
            return encode_pfm(img);
        case ImageFormat::exr:
            return encode_exr(img);
    }
    return {};
}

}  // namespace raycastd::engine
