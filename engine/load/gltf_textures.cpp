// glTF base-colour textures: material → texture → sampler + image (glTF 2.0 §3.8, §3.9), the
// image's bytes from a bufferView, a base64 data: URI (decoded by tinygltf, kept as they are by
// our image callback, gltf_loader.cpp) or a file beside the model (through the caller's
// ResourceReader, so confined to the scene root), and KHR_texture_transform.
//
// Everything here degrades to a warning: a texture that cannot be used leaves the material
// with its baseColorFactor alone, as the issue asks and as glTF viewers do.

#include <array>
#include <cmath>
#include <map>
#include <optional>

#include "engine/load/gltf_internal.h"
#include "engine/load/loaders.h"

namespace raycastd::engine::gltf {

namespace {

// glTF 2.0 §5.26 (sampler): the OpenGL enums it reuses.
constexpr int kNearest = 9728;
constexpr int kClampToEdge = 33071;
constexpr int kMirroredRepeat = 33648;

bool in_range(int index, std::size_t size) {
    return index >= 0 && static_cast<std::size_t>(index) < size;
}

TextureWrap to_wrap(int mode) {
    if (mode == kClampToEdge)
        return TextureWrap::clamp_to_edge;
    if (mode == kMirroredRepeat)
        return TextureWrap::mirrored_repeat;
    return TextureWrap::repeat;  // 10497 REPEAT, also the default (§5.26)
}

/// RFC 3986 §2.1 percent-decoding; glTF URIs are RFC 3986 URI references (§3.1). A malformed
/// escape is kept as it is (the file will then not be found, which is reported).
std::string percent_decode(std::string_view uri) {
    const auto hex = hex_digit;
    std::string out;
    for (std::size_t i = 0; i < uri.size(); ++i) {
        if (uri[i] == '%' && i + 2 < uri.size() && hex(uri[i + 1]) >= 0 && hex(uri[i + 2]) >= 0) {
            out += static_cast<char>(hex(uri[i + 1]) << 4 | hex(uri[i + 2]));
            i += 2;
        } else {
            out += uri[i];
        }
    }
    return out;
}

/// The encoded bytes of image `index`.
Result<std::string> image_bytes(const tinygltf::Model& m, std::size_t index,
                                const ResourceReader& read) {
    const tinygltf::Image& image = m.images[index];
    if (image.bufferView >= 0) {
        if (!in_range(image.bufferView, m.bufferViews.size())) {
            return Status::error(Code::model_load_failed, "bufferView does not exist");
        }
        // validate_buffers() proved every bufferView lies inside its buffer.
        const tinygltf::BufferView& view =
            m.bufferViews[static_cast<std::size_t>(image.bufferView)];
        const auto& data = m.buffers[static_cast<std::size_t>(view.buffer)].data;
        return std::string(reinterpret_cast<const char*>(data.data()) + view.byteOffset,
                           view.byteLength);
    }
    if (image.as_is)  // a data: URI, decoded by tinygltf and kept by keep_data_uri_image()
        return std::string(image.image.begin(), image.image.end());
    const std::string path = percent_decode(image.uri);
    if (Status st = detail::check_resource_uri(path); !st.ok())
        return st;
    return read(path);
}

/// KHR_texture_transform on a textureInfo: uv' = T·R·S·uv with T the offset, R the rotation
/// (counter-clockwise in uv space, which turns clockwise on the image since v runs down) and S
/// the scale, as the extension's README writes the matrix:
///   [ sx·cos r   sy·sin r   ox ]
///   [ −sx·sin r  sy·cos r   oy ]
/// Its texCoord, when present, overrides the textureInfo's.
void read_texture_transform(const tinygltf::TextureInfo& info, UvMapping& out) {
    auto it = info.extensions.find("KHR_texture_transform");
    if (it == info.extensions.end() || !it->second.IsObject())
        return;
    const tinygltf::Value& t = it->second;
    auto pair = [&](const char* key, double x, double y) -> std::array<double, 2> {
        if (!t.Has(key) || !t.Get(key).IsArray() || t.Get(key).ArrayLen() != 2)
            return {x, y};
        const auto& a = t.Get(key);
        if (!a.Get(0).IsNumber() || !a.Get(1).IsNumber())
            return {x, y};
        const double ax = a.Get(0).GetNumberAsDouble(), ay = a.Get(1).GetNumberAsDouble();
        return std::isfinite(ax) && std::isfinite(ay) ? std::array<double, 2>{ax, ay}
                                                      : std::array<double, 2>{x, y};
    };
    const auto offset = pair("offset", 0.0, 0.0);
    const auto scale = pair("scale", 1.0, 1.0);
    double r = 0.0;
    if (t.Has("rotation") && t.Get("rotation").IsNumber() &&
        std::isfinite(t.Get("rotation").GetNumberAsDouble()))
        r = t.Get("rotation").GetNumberAsDouble();
    out.matrix = {scale[0] * std::cos(r),  scale[1] * std::sin(r), offset[0],
                  -scale[0] * std::sin(r), scale[1] * std::cos(r), offset[1]};
    if (t.Has("texCoord") && t.Get("texCoord").IsNumber()) {
        const double c = t.Get("texCoord").GetNumberAsDouble();
        if (c >= 0.0 && c < 16.0 && c == std::floor(c))
            out.texcoord = static_cast<int>(c);
    }
}

/// Image `source` read (image_bytes) and decoded against the model's budget (decoded_pixels).
Result<std::shared_ptr<const TextureImage>> decoded_image(const tinygltf::Model& m,
                                                          std::size_t source,
                                                          const ResourceReader& read,
                                                          const LoadLimits& limits,
                                                          std::size_t& decoded_pixels) {
    auto bytes = image_bytes(m, source, read);
    if (!bytes)
        return bytes.status();
    return detail::decode_texture_image(*bytes, limits, decoded_pixels);
}

}  // namespace

std::vector<std::optional<std::array<double, 2>>> metallic_roughness_means(
    const tinygltf::Model& m, const ResourceReader& read, const LoadLimits& limits,
    std::size_t& decoded_pixels, std::vector<std::string>& warnings) {
    std::vector<std::optional<std::array<double, 2>>> means(m.materials.size());
    if (!limits.textures)
        return means;  // a query-only scene is never shaded
    std::map<std::size_t, std::optional<std::array<double, 2>>> by_image;
    for (std::size_t i = 0; i < m.materials.size(); ++i) {
        const tinygltf::TextureInfo& info =
            m.materials[i].pbrMetallicRoughness.metallicRoughnessTexture;
        if (info.index < 0)
            continue;
        const std::string where = "/materials/" + std::to_string(i);
        if (!in_range(info.index, m.textures.size()) ||
            !in_range(m.textures[static_cast<std::size_t>(info.index)].source, m.images.size())) {
            warnings.push_back(where +
                               ": its metallicRoughnessTexture has no image we can read; its "
                               "metallic and roughness factors stand alone");
            continue;
        }
        const auto source =
            static_cast<std::size_t>(m.textures[static_cast<std::size_t>(info.index)].source);
        if (!by_image.count(source)) {
            auto image = decoded_image(m, source, read, limits, decoded_pixels);
            std::optional<std::array<double, 2>> mean;
            if (image) {
                // glTF 2.0 §3.9.2: metalness in B, roughness in G, linear values (no sRGB).
                const std::vector<std::uint8_t>& rgb = (*image)->rgb;
                double g = 0.0, b = 0.0;
                for (std::size_t k = 0; k + 2 < rgb.size(); k += 3) {
                    g += rgb[k + 1];
                    b += rgb[k + 2];
                }
                const double n = 255.0 * static_cast<double>(rgb.size() / 3);
                mean = std::array<double, 2>{b / n, g / n};
            } else {
                warnings.push_back("/images/" + std::to_string(source) + ": " +
                                   image.status().message + "; material " + std::to_string(i) +
                                   " uses its metallic and roughness factors alone");
            }
            by_image[source] = mean;
        }
        means[i] = by_image[source];
    }
    return means;
}

std::vector<UvMapping> attach_base_color_textures(const tinygltf::Model& m,
                                                  const ResourceReader& read,
                                                  const LoadLimits& limits,
                                                  std::vector<Material>& materials,
                                                  std::vector<std::string>& warnings,
                                                  std::size_t& decoded_pixels) {
    std::vector<UvMapping> mappings(m.materials.size());
    std::map<std::size_t, std::shared_ptr<const TextureImage>> decoded;  // by image index
    std::map<std::size_t, std::string> failed;                           // by image index
    for (std::size_t i = 0; i < m.materials.size() && i < materials.size(); ++i) {
        const tinygltf::TextureInfo& info = m.materials[i].pbrMetallicRoughness.baseColorTexture;
        if (info.index < 0)
            continue;
        const std::string where = "/materials/" + std::to_string(i);
        if (!in_range(info.index, m.textures.size())) {
            warnings.push_back(where + ": baseColorTexture refers to texture " +
                               std::to_string(info.index) + ", which does not exist; not textured");
            continue;
        }
        const tinygltf::Texture& tex = m.textures[static_cast<std::size_t>(info.index)];
        if (!in_range(tex.source, m.images.size())) {
            warnings.push_back(where + ": its texture has no image we can read; not textured");
            continue;
        }
        const auto source = static_cast<std::size_t>(tex.source);
        if (!limits.textures) {
            // Not read nor decoded, but the texture coordinates are still read and checked, so
            // that a query-only scene accepts or refuses the file as a rendered one does.
            UvMapping& uv = mappings[i];
            uv.texcoord = info.texCoord >= 0 && info.texCoord < 16 ? info.texCoord : 0;
            read_texture_transform(info, uv);
            continue;
        }
        if (!decoded.count(source) && !failed.count(source)) {
            auto image = decoded_image(m, source, read, limits, decoded_pixels);
            if (image)
                decoded[source] = *image;
            else
                failed[source] = image.status().message;
        }
        if (auto f = failed.find(source); f != failed.end()) {
            warnings.push_back("/images/" + std::to_string(source) + ": " + f->second +
                               "; material " + std::to_string(i) + " uses its base colour alone");
            continue;
        }
        auto texture = std::make_shared<Texture>();
        texture->image = decoded[source];
        if (in_range(tex.sampler, m.samplers.size())) {
            const tinygltf::Sampler& s = m.samplers[static_cast<std::size_t>(tex.sampler)];
            texture->wrap_s = to_wrap(s.wrapS);
            texture->wrap_t = to_wrap(s.wrapT);
            texture->nearest = s.magFilter == kNearest;
        }
        materials[i].texture = std::move(texture);
        UvMapping& uv = mappings[i];
        uv.texcoord = info.texCoord >= 0 && info.texCoord < 16 ? info.texCoord : 0;
        read_texture_transform(info, uv);
    }
    return mappings;
}

}  // namespace raycastd::engine::gltf
