#pragma once
// Test helper: an RGB image encoded as PNG bytes (stb_image_write, which engine_tests links), for
// tests that hand texture images to the loaders.

#include <cstdint>
#include <string>
#include <vector>

#include <stb_image_write.h>

namespace raycastd::engine::testing {

/// width × height RGB texels, rows top to bottom, as a PNG file's bytes.
inline std::string png(int width, int height, const std::vector<std::uint8_t>& rgb) {
    std::string out;
    stbi_write_png_to_func(
        [](void* context, void* data, int size) {
            static_cast<std::string*>(context)->append(static_cast<const char*>(data),
                                                       static_cast<std::size_t>(size));
        },
        &out, width, height, 3, rgb.data(), width * 3);
    return out;
}

}  // namespace raycastd::engine::testing
