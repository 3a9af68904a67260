#include "engine/render/png.h"

#include <algorithm>
#include <cstdint>
#include <new>
#include <stdexcept>
#include <vector>

#include <tbb/parallel_for.h>
#include <zlib.h>

namespace raycastd::engine {

namespace {

/// Filtered bytes a band holds (whole rows, at least one): about ten bands in a 1024×768 image,
/// enough for two cores to share evenly, few enough that each deflate stream's set-up (~270 KB
/// of state) stays small against its work.
constexpr std::size_t kBandBytes = 256 * 1024;

/// The largest count zlib's unsigned int fields are given at once.
constexpr std::size_t kZlibStep = std::size_t{1} << 30;

/// A PNG chunk's length field holds at most 2^31 − 1 (§5.3).
constexpr std::size_t kMaxChunk = 0x7fffffffu;

/// One band of rows: its IDAT chunk (length, type, deflated bytes, CRC), and what the zlib
/// stream's trailer needs of it.
struct Band {
    std::string idat;
    uLong adler = 0;
    std::size_t raw_size = 0;
};

void put_be32(std::string& out, std::uint32_t v) {
    const char b[4] = {static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                       static_cast<char>(v >> 8), static_cast<char>(v)};
    out.append(b, 4);
}

/// A chunk (§5.3): length, type, data, and the CRC-32 of type and data.
void put_chunk(std::string& out, const char* type, const std::string& data) {
    if (data.size() > kMaxChunk)
        throw std::length_error("PNG chunk over 2^31 - 1 bytes");
    put_be32(out, static_cast<std::uint32_t>(data.size()));
    out.append(type, 4);
    out.append(data);
    uLong crc = crc32(0, reinterpret_cast<const Bytef*>(type), 4);
    crc = crc32_z(crc, reinterpret_cast<const Bytef*>(data.data()), data.size());
    put_be32(out, static_cast<std::uint32_t>(crc));
}

/// A z_stream for raw deflate (no zlib header or trailer: the bands are one stream's pieces),
/// ended when it goes out of scope.
class RawDeflate {
  public:
    RawDeflate() {
        // Level 1 and Z_RLE: run-length matches only (png.h says why). windowBits −15: raw.
        const int rc = deflateInit2(&s_, 1, Z_DEFLATED, -15, 8, Z_RLE);
        if (rc == Z_MEM_ERROR)
            throw std::bad_alloc();
        if (rc != Z_OK)
            throw std::runtime_error("zlib deflateInit2 failed");
    }
    ~RawDeflate() { deflateEnd(&s_); }
    RawDeflate(const RawDeflate&) = delete;
    RawDeflate& operator=(const RawDeflate&) = delete;

    /// Deflates `in` and appends it to `out`; the last band ends the stream (Z_FINISH), the
    /// others with a sync flush that byte-aligns them for the next band.
    void run(const std::vector<unsigned char>& in, bool last, std::string& out) {
        const std::size_t start = out.size();
        out.resize(start + deflateBound(&s_, in.size()) + 64);
        std::size_t in_left = in.size();
        s_.next_in = const_cast<Bytef*>(in.data());  // zlib's API is not const; it only reads
        std::size_t produced = start;
        for (;;) {
            if (s_.avail_in == 0 && in_left > 0) {
                const std::size_t take = std::min(in_left, kZlibStep);
                s_.avail_in = static_cast<uInt>(take);
                in_left -= take;
            }
            if (out.size() - produced < 64)
                out.resize(out.size() * 2);
            s_.next_out = reinterpret_cast<Bytef*>(&out[produced]);
            s_.avail_out = static_cast<uInt>(std::min(out.size() - produced, kZlibStep));
            const int flush = in_left > 0 ? Z_NO_FLUSH : (last ? Z_FINISH : Z_SYNC_FLUSH);
            const int rc = deflate(&s_, flush);
            produced = static_cast<std::size_t>(reinterpret_cast<char*>(s_.next_out) - out.data());
            if (rc == Z_STREAM_END)
                break;
            if (rc != Z_OK && rc != Z_BUF_ERROR)
                throw std::runtime_error("zlib deflate failed");
            // A sync flush is complete once deflate returns with output space left (zlib.h).
            if (flush == Z_SYNC_FLUSH && s_.avail_in == 0 && s_.avail_out != 0)
                break;
        }
        out.resize(produced);
    }

  private:
    z_stream s_{};
};

}  // namespace

std::string encode_png_rgb8(int width, int height,
                            const std::function<void(int y, unsigned char* out)>& row) {
    if (width <= 0 || height <= 0)
        throw std::invalid_argument("a PNG image has at least one pixel");
    const std::size_t bytes = 3 * static_cast<std::size_t>(width);
    const std::size_t stride = 1 + bytes;  // the filter type byte, then the row
    const int band_rows = static_cast<int>(
        std::clamp<std::size_t>(kBandBytes / stride, 1, static_cast<std::size_t>(height)));
    const int band_count = static_cast<int>((static_cast<std::int64_t>(height) + band_rows - 1) /
                                            band_rows);  // no int overflow
    std::vector<Band> bands(static_cast<std::size_t>(band_count));

    tbb::parallel_for(0, band_count, [&](int b) {
        const int y0 = b * band_rows;
        const int y1 = std::min(height, y0 + band_rows);
        std::vector<unsigned char> raw(stride * static_cast<std::size_t>(y1 - y0));
        for (int y = y0; y < y1; ++y) {
            unsigned char* r = &raw[stride * static_cast<std::size_t>(y - y0)];
            r[0] = 1;  // Sub: each byte minus the same channel's byte of the pixel to its left
            unsigned char* px = r + 1;
            row(y, px);
            for (std::size_t x = bytes - 1; x >= 3; --x)  // right to left: the left is unfiltered
                px[x] = static_cast<unsigned char>(px[x] - px[x - 3]);
        }
        Band& band = bands[static_cast<std::size_t>(b)];
        band.raw_size = raw.size();
        band.adler = adler32_z(adler32(0, nullptr, 0), raw.data(), raw.size());
        std::string data;
        if (b == 0) {
            // The zlib header (RFC 1950 §2.2): deflate with a 32 KB window (0x78), the fastest
            // level's flag and a check making the 16-bit value a multiple of 31 (0x01).
            data.push_back(static_cast<char>(0x78));
            data.push_back(static_cast<char>(0x01));
        }
        RawDeflate deflater;
        const bool last = b == band_count - 1;
        deflater.run(raw, last, data);
        if (!last)
            put_chunk(band.idat, "IDAT", data);
        else
            band.idat = std::move(data);  // made a chunk below, once the trailer is appended
    });

    // The zlib trailer: the Adler-32 of the whole filtered image, combined from the bands'.
    uLong adler = bands[0].adler;
    for (std::size_t b = 1; b < bands.size(); ++b)
        adler = adler32_combine64(adler, bands[b].adler, static_cast<z_off64_t>(bands[b].raw_size));
    std::string last = std::move(bands.back().idat);
    put_be32(last, static_cast<std::uint32_t>(adler));
    bands.back().idat.clear();
    put_chunk(bands.back().idat, "IDAT", last);

    std::string ihdr;  // §11.2.2: width, height, bit depth 8, colour type 2 (RGB), methods 0
    put_be32(ihdr, static_cast<std::uint32_t>(width));
    put_be32(ihdr, static_cast<std::uint32_t>(height));
    ihdr.append("\x08\x02\x00\x00\x00", 5);

    std::size_t size = 8 + 25 + 12;
    for (const Band& b : bands)
        size += b.idat.size();
    std::string out;
    out.reserve(size);
    out.append("\x89PNG\r\n\x1a\n", 8);  // §5.2
    put_chunk(out, "IHDR", ihdr);
    for (const Band& b : bands)
        out.append(b.idat);
    put_chunk(out, "IEND", std::string());
    return out;
}

}  // namespace raycastd::engine
