#include "bench/bench_files.h"

#include <cstdio>
#include <cstring>
#include <fstream>

#include <nlohmann/json.hpp>

namespace raycastd::bench {

std::string command_output(const std::string& cmd) {
    std::FILE* f = popen(cmd.c_str(), "r");
    if (!f)
        return {};
    std::string out;
    char line[4096];
    while (std::fgets(line, sizeof line, f))
        out += line;
    pclose(f);
    return out;
}

namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the PLY and .npy files are written as little-endian memory images");

bool write_bytes(std::ofstream& out, const void* data, std::size_t bytes) {
    out.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
    return static_cast<bool>(out);
}

/// The .npy header (NumPy NEP 1): magic, version 1.0, little-endian header length, then a
/// Python dict literal padded with spaces so that the data starts at a multiple of 64 bytes.
bool write_npy_raw(const std::string& path, const char* descr, const void* data,
                   std::size_t item_size, const std::vector<std::size_t>& shape) {
    std::string dict = std::string("{'descr': '") + descr + "', 'fortran_order': False, 'shape': (";
    std::size_t count = 1;
    for (std::size_t d : shape) {
        dict += std::to_string(d) + ", ";
        count *= d;
    }
    dict += "), }";
    const std::size_t preamble = 10;
    std::size_t total = preamble + dict.size() + 1;
    dict.append((64 - total % 64) % 64, ' ');
    dict += '\n';
    const auto header_len = static_cast<std::uint16_t>(dict.size());

    std::ofstream out(path, std::ios::binary);
    const char magic[8] = {'\x93', 'N', 'U', 'M', 'P', 'Y', 1, 0};
    return write_bytes(out, magic, sizeof magic) &&
           write_bytes(out, &header_len, sizeof header_len) &&
           write_bytes(out, dict.data(), dict.size()) && write_bytes(out, data, count * item_size);
}

}  // namespace

bool write_ply(const std::string& path, const Workload& w) {
    std::ofstream out(path, std::ios::binary);
    const std::string header =
        "ply\nformat binary_little_endian 1.0\n"
        "comment raycastd benchmark workload " +
        w.name + "\nelement vertex " + std::to_string(w.positions.size()) +
        "\nproperty float x\nproperty float y\nproperty float z\n"
        "element face " +
        std::to_string(w.triangles.size()) +
        "\nproperty list uchar int vertex_indices\nend_header\n";
    if (!write_bytes(out, header.data(), header.size()))
        return false;
    if (!w.positions.empty() &&
        !write_bytes(out, w.positions.data(), w.positions.size() * sizeof(w.positions[0]))) {
        return false;
    }
    // 13 bytes per face: the count, then three indices.
    std::vector<char> faces(13 * w.triangles.size());
    for (std::size_t i = 0; i < w.triangles.size(); ++i) {
        char* f = &faces[13 * i];
        f[0] = 3;
        std::memcpy(f + 1, w.triangles[i].data(), 12);
    }
    return write_bytes(out, faces.data(), faces.size());
}

bool write_sphere_scene(const std::string& path, const Workload& w) {
    nlohmann::json objects = nlohmann::json::array();
    for (const auto& s : w.spheres) {
        objects.push_back({{"type", "sphere"}, {"center", {s[0], s[1], s[2]}}, {"radius", s[3]}});
    }
    std::ofstream out(path);
    out << nlohmann::json{{"objects", objects}}.dump();
    return static_cast<bool>(out);
}

bool write_npy(const std::string& path, const float* data, std::vector<std::size_t> shape) {
    return write_npy_raw(path, "<f4", data, sizeof(float), shape);
}

bool write_npy(const std::string& path, const std::uint32_t* data, std::vector<std::size_t> shape) {
    return write_npy_raw(path, "<u4", data, sizeof(std::uint32_t), shape);
}

bool write_rays(const std::string& path, const std::vector<RayRecord>& rays) {
    return write_npy(path, &rays.data()->ox, {rays.size(), 8});
}

bool write_hits(const std::string& stem, const RawHits& hits) {
    const std::size_t n = hits.t.size();
    return write_npy(stem + "_t.npy", hits.t.data(), {n}) &&
           write_npy(stem + "_object.npy", hits.object.data(), {n}) &&
           write_npy(stem + "_primitive.npy", hits.primitive.data(), {n});
}

bool write_mesh_arrays(const std::string& stem, const Workload& w) {
    return write_npy(stem + "_vertices.npy", w.positions.data()->data(), {w.positions.size(), 3}) &&
           write_npy(stem + "_triangles.npy", w.triangles.data()->data(), {w.triangles.size(), 3});
}

}  // namespace raycastd::bench
