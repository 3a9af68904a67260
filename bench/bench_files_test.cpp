#include "bench/bench_files.h"

#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "engine/load/model_loader.h"

namespace raycastd::bench {
namespace {

std::string temp_path(const std::string& name) {
    return ::testing::TempDir() + "raycastd_bench_" + name;
}

std::string read_all(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// NumPy's format 1.0: magic, version, a little-endian header length, a dict padded so that the
// data starts at a multiple of 64 bytes, then the raw values.
TEST(Npy, HeaderIsAlignedAndDescribesTheArray) {
    const float values[6] = {1, 2, 3, 4, 5, 6};
    const std::string path = temp_path("a.npy");
    ASSERT_TRUE(write_npy(path, values, {2, 3}));
    const std::string bytes = read_all(path);
    ASSERT_GE(bytes.size(), 10u);
    EXPECT_EQ(bytes.substr(0, 6), "\x93NUMPY");
    const std::size_t header_len =
        static_cast<unsigned char>(bytes[8]) | static_cast<unsigned char>(bytes[9]) << 8;
    const std::size_t data_start = 10 + header_len;
    EXPECT_EQ(data_start % 64, 0u);
    const std::string header = bytes.substr(10, header_len);
    EXPECT_NE(header.find("'descr': '<f4'"), std::string::npos);
    EXPECT_NE(header.find("'shape': (2, 3, )"), std::string::npos);
    EXPECT_EQ(header.back(), '\n');
    ASSERT_EQ(bytes.size(), data_start + sizeof values);
    EXPECT_EQ(std::memcmp(bytes.data() + data_start, values, sizeof values), 0);
    std::remove(path.c_str());
}

// The PLY the HTTP peer posts must load in raycastd's own loader as the same mesh.
TEST(Ply, LoadsBackAsTheSameMesh) {
    const Workload w = make_icosphere(2);
    const std::string path = temp_path("ico.ply");
    ASSERT_TRUE(write_ply(path, w));
    const std::string bytes = read_all(path);
    auto model =
        engine::load_model(bytes, engine::ModelFormat::ply, engine::no_resources(), "ico.ply");
    ASSERT_TRUE(model.ok()) << model.status().message;
    ASSERT_EQ(model->parts.size(), 1u);
    const engine::TriangleMesh& m = model->parts[0].mesh;
    ASSERT_EQ(m.triangles.size(), w.triangles.size());
    EXPECT_EQ(m.triangles[17], w.triangles[17]);
    EXPECT_EQ(m.positions[w.triangles[17][1]].y, double{w.positions[w.triangles[17][1]][1]});
    std::remove(path.c_str());
}

TEST(CommandOutput, IsWhatTheCommandPrintedOrNothing) {
    EXPECT_EQ(command_output("printf '{\"a\": 1}\\n'"), "{\"a\": 1}\n");
    EXPECT_EQ(command_output("true"), "");
}

}  // namespace
}  // namespace raycastd::bench
