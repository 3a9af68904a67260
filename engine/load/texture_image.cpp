// Texture images for base-colour textures: PNG and JPEG through Debian's libstb (stb_image).
//
// Only those two formats are handed to stb_image (chosen by their signatures, glTF 2.0 §3.9.1
// allows no other), so its GIF, PSD, HDR and PIC decoders are never reached by a scene file.
// The dimensions are read from the header with stbi_info_from_memory and checked against the
// pixel limit before a single pixel is decoded: a 200-byte PNG can declare 65,535² pixels
// (a decompression bomb). Failures come back as messages that the loaders turn into warnings:
// an image we cannot use costs the texture, never the model.

#include <climits>

#include <stb_image.h>

#include "engine/load/loaders.h"

namespace raycastd::engine::detail {

namespace {

bool is_png(std::string_view b) {
    return b.size() >= 8 && b.substr(0, 8) == std::string_view("\x89PNG\r\n\x1a\n", 8);
}

bool is_jpeg(std::string_view b) {
    return b.size() >= 3 && b.substr(0, 3) == std::string_view("\xFF\xD8\xFF", 3);
}

}  // namespace

Result<std::shared_ptr<const TextureImage>> decode_texture_image(std::string_view bytes,
                                                                 const LoadLimits& limits,
                                                                 std::size_t& decoded) {
    auto refuse = [](std::string why) {
        return Status::error(Code::model_load_failed, std::move(why));
    };
    if (!is_png(bytes) && !is_jpeg(bytes))
        return refuse("not a PNG or JPEG image");
    if (bytes.size() > static_cast<std::size_t>(INT_MAX))
        return refuse("image over 2 GiB");
    const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
    const int size = static_cast<int>(bytes.size());
    int w = 0, h = 0, channels = 0;
    if (!stbi_info_from_memory(data, size, &w, &h, &channels) || w <= 0 || h <= 0) {
        const char* why = stbi_failure_reason();
        return refuse(std::string("unreadable image header") +
                      (why ? std::string(": ") + why : ""));
    }
    const auto pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
    if (pixels > limits.max_texture_pixels) {
        return refuse(std::to_string(w) + "×" + std::to_string(h) + " image is over the limit of " +
                      std::to_string(limits.max_texture_pixels) + " pixels (--max-texture-pixels)");
    }
    if (pixels > limits.max_texture_pixels_total ||
        decoded > limits.max_texture_pixels_total - pixels) {
        return refuse(std::to_string(w) + "×" + std::to_string(h) +
                      " image is over what is left of the scene's texture budget (" +
                      std::to_string(limits.max_texture_pixels_total - decoded) +
                      " pixels; 4 × --max-texture-pixels for all its images together)");
    }
    int dw = 0, dh = 0;
    stbi_uc* px = stbi_load_from_memory(data, size, &dw, &dh, &channels, 3);
    if (!px) {
        const char* why = stbi_failure_reason();
        return refuse(std::string("image does not decode") + (why ? std::string(": ") + why : ""));
    }
    auto image = std::make_shared<TextureImage>();
    image->width = dw;
    image->height = dh;
    image->rgb.assign(px, px + static_cast<std::size_t>(dw) * static_cast<std::size_t>(dh) * 3);
    stbi_image_free(px);
    decoded += pixels;
    return std::shared_ptr<const TextureImage>(std::move(image));
}

}  // namespace raycastd::engine::detail
