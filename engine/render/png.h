#pragma once
// PNG files of 8-bit RGB images, written here with zlib rather than by stb_image_write.
//
// Why not stb. Its deflate took ~46 ms of a 1024×768 preview's 92 ms encode on this 2-core
// machine (the sRGB curve the other 46; image.cpp), for a 244 KB file. zlib's run-length
// strategy (Z_RLE: matches at distance 1 only; the Sub filter turns a row's runs of one colour
// into runs of zeros) wrote the same image in 16 ms and 211 KB, on one core. Z_RLE looks back one
// byte, so the image can be cut into bands of rows deflated independently, in parallel, at
// almost no cost in size: each band but the last ends in a sync flush (an empty stored block that
// byte-aligns it, RFC 1951 §3.2.4), the bands are concatenated in order into one zlib stream
// (RFC 1950) whose Adler-32 is combined from the bands'. The bands are fixed by the image's
// height, not by the threads, so an image always encodes to the same bytes.

#include <functional>
#include <string>

namespace raycastd::engine {

/// A PNG file (PNG specification, 2nd ed., ISO/IEC 15948:2003) of a width × height 8-bit RGB
/// image, not interlaced, every row with the Sub filter (§9.2, type 1). `row(y, out)` writes row
/// y's width·3 bytes (R, G, B, left to right; rows from the top) to `out`; it is called once per
/// row, from several threads at once (each row on one thread). Throws std::bad_alloc when zlib
/// cannot allocate, std::length_error for an image too large for one PNG chunk (2^31 − 1 bytes).
std::string encode_png_rgb8(int width, int height,
                            const std::function<void(int y, unsigned char* out)>& row);

}  // namespace raycastd::engine
