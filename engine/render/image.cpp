#include "engine/render/image.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "engine/render/png.h"

namespace raycastd::engine {

namespace {

std::vector<unsigned char> to_8bit(const Image& img, bool linear) {
    std::vector<unsigned char> out(img.rgb.size());
    encode_8bit(img.rgb.data(), img.rgb.size(), linear, out.data());
    return out;
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

unsigned char srgb_encode_formula(float linear) {
    if (!(linear > 0.0f))
        return 0;  // also NaN
    if (linear >= 1.0f)
        return 255;
    // IEC 61966-2-1: 12.92·c below 0.0031308, else 1.055·c^(1/2.4) − 0.055.
    const float s =
        linear <= 0.0031308f ? 12.92f * linear : 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
    return static_cast<unsigned char>(std::lround(s * 255.0f));
}

namespace {

/// srgb_encode_formula, tabulated. Every image is written through the curve, three powf calls a
/// pixel: 46 ms of a 1024×768 preview's 92 ms PNG encode, and the same again in adaptive
/// sampling's first pass, which compares the 8-bit values shown (render.cpp). The table splits
/// [2^-13, 1) into buckets by a float's exponent and top 7 mantissa bits (its bits >> 16). The
/// code rises across a bucket by at most the curve's slope times its width, 255 · 1.055/2.4 ·
/// c^(1/2.4) · 2^-7 ≤ 0.88 (the linear segment: 12.92 · 255 · c · 2^-7 ≤ 0.08), so each bucket
/// holds its first value's code and at most one step, at the first float whose code is higher.
/// Below 2^-13 the code is 0 (12.92 · 255 · 2^-13 = 0.40 < 1/2).
/// Image.SrgbTableMatchesTheFormulaOnEveryFloat compares the two on every float in [2^-13, 1]
/// and shows the formula's 0 just below 2^-13, below which it only falls.
class SrgbTable {
  public:
    SrgbTable() {
        for (std::uint32_t i = 0; i < kBuckets; ++i) {
            const std::uint32_t first = (kFirstBucket + i) << 16;
            const std::uint32_t last = first | 0xffffu;
            base_[i] = srgb_encode_formula(from_bits(first));
            step_[i] = 2.0f;  // no step in this bucket: no value in [0, 1) reaches it
            if (srgb_encode_formula(from_bits(last)) == base_[i])
                continue;
            // The first float in (first, last] whose code is above base_[i] (bisection).
            std::uint32_t lo = first, hi = last;
            while (hi - lo > 1) {
                const std::uint32_t mid = lo + (hi - lo) / 2;
                (srgb_encode_formula(from_bits(mid)) > base_[i] ? hi : lo) = mid;
            }
            step_[i] = from_bits(hi);
        }
    }
    unsigned char operator()(float linear) const {
        if (!(linear >= kFirst))
            return 0;  // also NaN
        if (linear >= 1.0f)
            return 255;
        std::uint32_t bits;
        std::memcpy(&bits, &linear, sizeof bits);
        const std::uint32_t i = (bits >> 16) - kFirstBucket;
        return static_cast<unsigned char>(base_[i] + (linear >= step_[i] ? 1 : 0));
    }

  private:
    static float from_bits(std::uint32_t bits) {
        float f;
        std::memcpy(&f, &bits, sizeof f);
        return f;
    }
    static constexpr float kFirst = 0x1p-13f;
    static constexpr std::uint32_t kFirstBucket = (127u - 13u) << 7;  // bits(2^-13) >> 16
    static constexpr std::uint32_t kBuckets = 13u << 7;               // 2^-13 .. 1: 13 octaves
    unsigned char base_[kBuckets];
    float step_[kBuckets];
};

const SrgbTable& srgb_table() {
    static const SrgbTable table;
    return table;
}

}  // namespace

unsigned char srgb_encode(float linear) {
    return srgb_table()(linear);
}

namespace {

/// Round-half-up of c · 255 for c in [0, 1], as std::lround gives it (non-negative), without a
/// libm call: the float product is exact in double, and adding 1/2 to it there is exact from
/// 2^-29 on (below, the sum rounds to 1/2 or just above it, which truncates to 0 all the same).
unsigned char linear_8bit(float value) {
    const float c = std::isfinite(value) ? std::clamp(value, 0.0f, 1.0f) : 0.0f;
    return static_cast<unsigned char>(static_cast<double>(c * 255.0f) + 0.5);
}

}  // namespace

unsigned char encode_8bit(float value, bool linear) {
    return linear ? linear_8bit(value) : srgb_encode(value);
}

void encode_8bit(const float* values, std::size_t n, bool linear, unsigned char* out) {
    if (linear) {
        for (std::size_t i = 0; i < n; ++i)
            out[i] = linear_8bit(values[i]);
        return;
    }
    const SrgbTable& table = srgb_table();
    for (std::size_t i = 0; i < n; ++i)
        out[i] = table(values[i]);
}

std::string encode_image(const Image& img, ImageFormat format, bool linear_8bit) {
    switch (format) {
        case ImageFormat::png: {
            const std::size_t n = 3 * static_cast<std::size_t>(img.width);
            return encode_png_rgb8(img.width, img.height, [&](int y, unsigned char* out) {
                encode_8bit(&img.rgb[n * static_cast<std::size_t>(y)], n, linear_8bit, out);
            });
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
