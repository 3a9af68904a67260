// glTF 2.0 → LoadedModel, through tinygltf 2.7 (Debian's libtinygltf).
//
// tinygltf parses the JSON and decodes buffers; everything after that is ours and checked
// before use: the GLB container (tinygltf 2.7 lets a BIN chunk's 8-byte header run past the
// declared length and ignores the version), every accessor and bufferView range
// (gltf_accessors.cpp), every index against its vertex count, and the node graph (cycles,
// shared children, depth). tinygltf's file access is routed to the caller's ResourceReader
// and allowed only for the URIs of the document's buffers; tinygltf neither reads nor decodes
// images: the base-colour textures that materials use are read and decoded afterwards, by
// us (gltf_textures.cpp). nlohmann/json, tinygltf's own parser, is used beforehand to list
// those URIs and, after a failed parse, to name an unsupported required extension.

#include <algorithm>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "engine/load/gltf_internal.h"
#include "engine/load/loaders.h"

namespace raycastd::engine::detail {

namespace {

constexpr std::uint32_t kGlbMagic = 0x46546C67;   // "glTF"
constexpr std::uint32_t kChunkJson = 0x4E4F534A;  // "JSON"
constexpr std::uint32_t kChunkBin = 0x004E4942;   // "BIN\0"

// Extensions whose absence of support cannot change the geometry or lighting we produce:
// lights, quantized attributes, texture transforms and emissive strength we implement.
const std::set<std::string> kSupportedRequired = {"KHR_lights_punctual", "KHR_mesh_quantization",
                                                  "KHR_texture_transform",
                                                  "KHR_materials_emissive_strength"};

std::uint32_t read_u32(std::string_view b, std::size_t at) {
    return static_cast<std::uint32_t>(static_cast<unsigned char>(b[at])) |
           static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 1])) << 8 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 2])) << 16 |
           static_cast<std::uint32_t>(static_cast<unsigned char>(b[at + 3])) << 24;
}

/// The GLB container as tinygltf should see it, and the BIN chunk's length (0 if absent).
struct Glb {
    std::string_view original;
    std::string patched;  ///< set when unknown trailing chunks were cut off (header rewritten)
    std::size_t bin_length = 0;
    bool has_bin = false;

    /// Header + JSON [+ BIN], as tinygltf should see it.
    std::string_view bytes() const { return patched.empty() ? original : patched; }
};

// Binary glTF layout, glTF 2.0 §4.4: a 12-byte header (magic, version 2, total length), then
// chunks of (uint32 length, uint32 type, data); chunk 0 is JSON, an optional BIN chunk comes
// second; chunk lengths are multiples of 4; unknown chunk types are ignored. Bytes after the
// declared length are ignored with a warning, as the glTF-Validator rates them.
Result<std::string_view> check_glb_header(std::string_view b, std::string_view name,
                                          std::vector<std::string>& warnings) {
    if (b.size() < 12) {
        return load_error(name, "truncated GLB: " + std::to_string(b.size()) +
                                    " bytes, the header alone needs 12");
    }
    if (read_u32(b, 0) != kGlbMagic)
        return load_error(name, "not a GLB file (bad magic)");
    const std::uint32_t version = read_u32(b, 4);
    if (version != 2) {
        return Status::error(Code::unsupported_format, std::string(name) + ": GLB version " +
                                                           std::to_string(version) +
                                                           " (only 2 is supported)");
    }
    const std::size_t length = read_u32(b, 8);
    if (length > b.size()) {
        return load_error(name, "truncated GLB: header declares " + std::to_string(length) +
                                    " bytes, only " + std::to_string(b.size()) + " present");
    }
    if (length < 12)
        return load_error(name, "GLB header declares fewer than 12 bytes");
    if (length < b.size()) {
        warnings.push_back(std::to_string(b.size() - length) +
                           " bytes after the end of the GLB stream ignored");
    }
    return b.substr(0, length);
}

Result<Glb> check_glb(std::string_view bytes, std::string_view name,
                      std::vector<std::string>& warnings) {
    auto header = check_glb_header(bytes, name, warnings);
    if (!header)
        return header.status();
    const std::string_view b = *header;
    Glb glb;
    std::size_t at = 12, keep = 12;
    for (int chunk = 0; at < b.size(); ++chunk) {
        auto chunk_error = [&](const std::string& what) {
            return load_error(name, "GLB chunk " + std::to_string(chunk) + ": " + what);
        };
        if (b.size() - at < 8)
            return chunk_error("truncated chunk header");
        const std::size_t len = read_u32(b, at);
        const std::uint32_t type = read_u32(b, at + 4);
        if (len > b.size() - at - 8) {
            return chunk_error(std::to_string(len) + " bytes run past the end of the file");
        }
        if (len % 4 != 0)
            return chunk_error("length is not a multiple of 4");
        if (chunk == 0 && (type != kChunkJson || len == 0)) {
            return chunk_error("the first chunk must be non-empty JSON");
        }
        if (chunk > 0 && type == kChunkJson)
            return chunk_error("a second JSON chunk");
        if (type == kChunkBin) {
            if (chunk != 1)
                return chunk_error("the BIN chunk must directly follow the JSON chunk");
            glb.has_bin = true;
            glb.bin_length = len;
        }
        at += 8 + len;
        if (chunk == 0 || type == kChunkBin)
            keep = at;
    }
    if (at == 12)
        return load_error(name, "GLB has no JSON chunk");
    glb.original = b;
    if (keep != b.size()) {
        // Hand tinygltf only the chunks it understands, with the header length to match.
        glb.patched.assign(b.data(), keep);
        for (std::size_t i = 0; i < 4; ++i) {
            glb.patched[8 + i] = static_cast<char>((keep >> (8 * i)) & 0xFF);
        }
    }
    return glb;
}

/// The URI as tinygltf hands it to the file-system callbacks: its dlib::urldecode turns "%xx"
/// into the byte and, unlike RFC 3986, '+' into a space.
std::string tinygltf_urldecode(std::string_view uri) {
    auto hex = [](char c) { return std::max(gltf::hex_digit(c), 0); };  // dlib reads junk as 0
    std::string out;
    for (std::size_t i = 0; i < uri.size(); ++i) {
        if (uri[i] == '+') {
            out += ' ';
        } else if (uri[i] == '%' && i + 2 < uri.size()) {
            out += static_cast<char>(hex(uri[i + 1]) << 4 | hex(uri[i + 2]));
            i += 2;
        } else {
            out += uri[i];
        }
    }
    return out;
}

/// The decoded URIs of the document's buffers. tinygltf decodes base64 data: URIs itself; any
/// other data: URI reaches the file-system callbacks, which then explain the refusal.
std::set<std::string> buffer_uris(const nlohmann::json& doc) {
    std::set<std::string> out;
    if (!doc.is_object() || !doc.contains("buffers") || !doc["buffers"].is_array())
        return out;
    for (const auto& b : doc["buffers"]) {
        if (!b.is_object() || !b.contains("uri") || !b["uri"].is_string())
            continue;
        const std::string& uri = b["uri"].get_ref<const std::string&>();
        out.insert(tinygltf_urldecode(uri));
    }
    return out;
}

/// tinygltf's file-system callbacks, answered from the ResourceReader for the buffers' URIs
/// only. Each is read at most once (tinygltf asks "exists?" before "read"). Anything else is an
/// image, reported missing without being read: a missing image is only a warning to tinygltf.
class ResourceBridge {
  public:
    ResourceBridge(const ResourceReader& read, std::set<std::string> buffers)
        : read_(read), buffers_(std::move(buffers)) {}

    tinygltf::FsCallbacks callbacks() {
        return {&ResourceBridge::exists, &ResourceBridge::expand, &ResourceBridge::read_file,
                &ResourceBridge::write_file, this};
    }

    /// Why the first buffer that could not be read failed (empty if none failed); tinygltf
    /// only says "File not found".
    const std::string& failure() const { return failure_; }

  private:
    const Result<std::string>& fetch(std::string path) {
        // tinygltf retries a relative name as "./name"; both are the same resource.
        if (path.rfind("./", 0) == 0)
            path.erase(0, 2);
        auto it = cache_.find(path);
        if (it != cache_.end())
            return it->second;
        Status refused =
            path.rfind("data:", 0) == 0
                ? Status::error(Code::model_load_failed, "only base64 data: URIs are supported")
                : check_resource_uri(path);
        if (refused.ok() && !buffers_.count(path)) {
            refused = Status::error(Code::not_found,
                                    "'" + path + "' is not a buffer; images are not loaded");
        }
        auto result = refused.ok() ? read_(path) : Result<std::string>(refused);
        if (!result.ok() && buffers_.count(path) && failure_.empty()) {
            failure_ = "buffer '" + path + "': " + result.status().message;
        }
        return cache_.emplace(path, std::move(result)).first->second;
    }

    static bool exists(const std::string& path, void* self) {
        return static_cast<ResourceBridge*>(self)->fetch(path).ok();
    }
    static std::string expand(const std::string& path, void*) { return path; }
    static bool read_file(std::vector<unsigned char>* out, std::string* err,
                          const std::string& path, void* self) {
        const auto& r = static_cast<ResourceBridge*>(self)->fetch(path);
        if (!r.ok()) {
            if (err)
                *err = r.status().message;
            return false;
        }
        out->assign(r->begin(), r->end());
        return true;
    }
    static bool write_file(std::string*, const std::string&, const std::vector<unsigned char>&,
                           void*) {
        return false;
    }

    const ResourceReader& read_;
    std::set<std::string> buffers_;
    std::map<std::string, Result<std::string>> cache_;
    std::string failure_;
};

/// tinygltf's image callback. Images are decoded later, and only those a material uses
/// (gltf_textures.cpp), so nothing is decoded here; but a data: URI's bytes reach us only
/// through this callback (tinygltf decodes the base64 and keeps no URI), so those are kept as
/// they are (`as_is`). Images in bufferViews are read from their buffer later; external files
/// never get here (the file-system callbacks refuse them to tinygltf).
bool keep_data_uri_image(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                         const unsigned char* bytes, int size, void*) {
    if (image->bufferView < 0 && image->uri.empty() && bytes && size > 0) {
        image->image.assign(bytes, bytes + size);
        image->as_is = true;
    }
    return true;
}

/// The first entry of the document's extensionsRequired we do not support, if any; nullopt
/// also when the JSON did not parse (the caller then reports tinygltf's own error).
std::optional<std::string> unsupported_required_extension(const nlohmann::json& doc) {
    if (!doc.is_object() || !doc.contains("extensionsRequired") ||
        !doc["extensionsRequired"].is_array()) {
        return std::nullopt;
    }
    for (const auto& ext : doc["extensionsRequired"]) {
        if (ext.is_string() && !kSupportedRequired.count(ext.get<std::string>())) {
            return ext.get<std::string>();
        }
    }
    return std::nullopt;
}

/// tinygltf's warnings, minus those about images (we never load them on purpose).
void add_tinygltf_warnings(const std::string& warn, std::vector<std::string>& out) {
    std::istringstream lines(warn);
    for (std::string line; std::getline(lines, line);) {
        if (line.empty() || line.find("image[") != std::string::npos ||
            line.find("File not found") != std::string::npos)
            continue;
        out.push_back("glTF: " + line);
    }
}

Result<tinygltf::Model> parse(std::string_view bytes, bool binary, const ResourceReader& read,
                              std::string_view name, std::vector<std::string>& warnings, Glb& glb) {
    if (bytes.size() > std::numeric_limits<unsigned int>::max()) {
        return Status::error(Code::too_large,
                             std::string(name) + ": glTF files over 4 GiB are not supported");
    }
    std::string_view json_text = bytes;
    if (binary) {
        auto checked = check_glb(bytes, name, warnings);
        if (!checked)
            return checked.status();
        glb = std::move(*checked);
        json_text = glb.bytes().substr(20, read_u32(glb.bytes(), 12));
    }
    const auto doc = nlohmann::json::parse(json_text.begin(), json_text.end(), nullptr,
                                           /*allow_exceptions=*/false);
    ResourceBridge bridge(read, buffer_uris(doc));
    tinygltf::TinyGLTF loader;
    loader.SetFsCallbacks(bridge.callbacks());
    loader.SetImageLoader(&keep_data_uri_image, nullptr);
    tinygltf::Model model;
    std::string err, warn;
    bool ok;
    if (binary) {
        const std::string_view view = glb.bytes();
        ok = loader.LoadBinaryFromMemory(&model, &err, &warn,
                                         reinterpret_cast<const unsigned char*>(view.data()),
                                         static_cast<unsigned int>(view.size()), "");
    } else {
        ok = loader.LoadASCIIFromString(&model, &err, &warn, bytes.data(),
                                        static_cast<unsigned int>(bytes.size()), "");
    }
    add_tinygltf_warnings(warn, warnings);
    if (!ok) {
        // tinygltf trips over what an unsupported required extension leaves out (a Draco mesh
        // has accessors without bufferViews) before it reports the extension; say the cause.
        if (auto ext = unsupported_required_extension(doc)) {
            return load_error(name, "required extension " + *ext + " is not supported");
        }
        if (!bridge.failure().empty())
            return load_error(name, bridge.failure());
        while (!err.empty() && (err.back() == '\n' || err.back() == ' '))
            err.pop_back();
        return load_error(name, err.empty() ? "glTF parse failed" : err);
    }
    return model;
}

/// What tinygltf accepts but we must not: unknown required extensions, a wrong asset version,
/// GLB buffers that do not match the BIN chunk (only buffer 0 may live in it; glTF 2.0
/// §4.4.3.3 lets the chunk exceed the buffer's byteLength by up to 3 padding bytes, and more is
/// a warning, as the glTF-Validator rates it).
Status check_model(const tinygltf::Model& m, const Glb& glb, bool binary,
                   std::vector<std::string>& warnings) {
    for (const std::string& ext : m.extensionsRequired) {
        if (!kSupportedRequired.count(ext))
            return Status::error(Code::model_load_failed,
                                 "required extension " + ext + " is not supported");
    }
    const std::string& v = m.asset.version;
    if (v.empty() || v[0] != '2' || (v.size() > 1 && v[1] != '.')) {
        return Status::error(Code::unsupported_format,
                             "glTF asset version '" + v + "' (only 2.x is supported)");
    }
    if (binary) {
        for (std::size_t i = 0; i < m.buffers.size(); ++i) {
            if (!m.buffers[i].uri.empty())
                continue;
            if (i != 0)
                return Status::error(Code::model_load_failed,
                                     "/buffers/" + std::to_string(i) +
                                         " has no uri (only buffer 0 may use the GLB BIN chunk)");
            if (!glb.has_bin)
                return Status::error(Code::model_load_failed,
                                     "/buffers/0 refers to a GLB BIN chunk that is missing");
            if (glb.bin_length > m.buffers[0].data.size() + 3) {
                warnings.push_back("GLB BIN chunk (" + std::to_string(glb.bin_length) +
                                   " bytes) is longer than /buffers/0 (" +
                                   std::to_string(m.buffers[0].data.size()) + " bytes)");
            }
        }
    }
    return gltf::validate_buffers(m);
}

}  // namespace

Result<LoadedModel> load_gltf(std::string_view bytes, bool binary, const ResourceReader& read,
                              std::string_view name, const LoadLimits& limits) {
    LoadedModel out;
    Glb glb;
    auto parsed = parse(bytes, binary, read, name, out.warnings, glb);
    if (!parsed)
        return parsed.status();
    const tinygltf::Model& m = *parsed;
    if (Status st = check_model(m, glb, binary, out.warnings); !st.ok())
        return with_name(name, st);
    if (Status st = gltf::build_model(m, name, read, limits, out); !st.ok())
        return with_name(name, st);
    if (Status st = finish_model(out, name, limits); !st.ok())
        return st;
    return out;
}

}  // namespace raycastd::engine::detail
