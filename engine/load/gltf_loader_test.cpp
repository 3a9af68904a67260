// The glTF loader on small hand-built documents: topology conversion, accessor decoding
// (strides, sparse, quantized), node transforms and the graph checks, materials, lights,
// cameras, GLB containers and resource access. Each document embeds its buffer as a base64
// data URI unless a test is about external files.

#include <cmath>
#include <cstring>
#include <map>

#include <gtest/gtest.h>

#include "engine/load/model_loader.h"
#include "engine/testing/png.h"

namespace raycastd::engine {
namespace {

std::string base64(const std::string& in) {
    static const char* const k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    std::size_t i = 0;
    for (; i + 2 < in.size(); i += 3) {
        const auto n = static_cast<std::uint32_t>(static_cast<unsigned char>(in[i])) << 16 |
                       static_cast<std::uint32_t>(static_cast<unsigned char>(in[i + 1])) << 8 |
                       static_cast<unsigned char>(in[i + 2]);
        for (int s = 18; s >= 0; s -= 6)
            out += k[(n >> s) & 63];
    }
    if (i < in.size()) {
        std::uint32_t n = static_cast<std::uint32_t>(static_cast<unsigned char>(in[i])) << 16;
        if (i + 1 < in.size())
            n |= static_cast<std::uint32_t>(static_cast<unsigned char>(in[i + 1])) << 8;
        out += k[(n >> 18) & 63];
        out += k[(n >> 12) & 63];
        out += i + 1 < in.size() ? k[(n >> 6) & 63] : '=';
        out += '=';
    }
    return out;
}

/// Builds a one-buffer glTF document: raw data, bufferViews and accessors are added in order
/// and the rest of the document (meshes, nodes, scenes, ...) is passed to json().
class Doc {
  public:
    template <class T>
    std::size_t add(const std::vector<T>& values) {
        while (bin_.size() % 4 != 0)
            bin_ += '\0';
        const std::size_t offset = bin_.size();
        bin_.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
        return offset;
    }
    int view(std::size_t offset, std::size_t length, int stride = 0) {
        views_.push_back(R"({"buffer":0,"byteOffset":)" + std::to_string(offset) +
                         R"(,"byteLength":)" + std::to_string(length) +
                         (stride ? R"(,"byteStride":)" + std::to_string(stride) : "") + "}");
        return static_cast<int>(views_.size() - 1);
    }
    /// An accessor; `extra` is appended inside its object (e.g. R"(,"normalized":true)").
    int accessor(int view, int component_type, std::size_t count, const char* type,
                 std::size_t offset = 0, const std::string& extra = "") {
        accessors_.push_back((view >= 0 ? R"({"bufferView":)" + std::to_string(view) + "," : "{") +
                             R"("byteOffset":)" + std::to_string(offset) + R"(,"componentType":)" +
                             std::to_string(component_type) + R"(,"count":)" +
                             std::to_string(count) + R"(,"type":")" + type + "\"" + extra + "}");
        return static_cast<int>(accessors_.size() - 1);
    }
    /// Floats packed as VEC3 positions with their own view; returns the accessor.
    int positions(const std::vector<float>& xyz) {
        return accessor(view(add(xyz), xyz.size() * 4), 5126, xyz.size() / 3, "VEC3");
    }
    std::string json(const std::string& rest, const std::string& buffer_uri = "") const {
        const std::string uri = buffer_uri.empty()
                                    ? "data:application/octet-stream;base64," + base64(bin_)
                                    : buffer_uri;
        return R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":)" +
               std::to_string(bin_.size()) + R"(,"uri":")" + uri + R"("}],"bufferViews":[)" +
               join(views_) + R"(],"accessors":[)" + join(accessors_) + "]" +
               (rest.empty() ? "" : "," + rest) + "}";
    }
    const std::string& bin() const { return bin_; }

  private:
    static std::string join(const std::vector<std::string>& parts) {
        std::string out;
        for (const auto& p : parts)
            out += (out.empty() ? "" : ",") + p;
        return out;
    }
    std::string bin_;
    std::vector<std::string> views_, accessors_;
};

Result<LoadedModel> load(const std::string& json, const ResourceReader& reader = no_resources()) {
    return load_model(json, ModelFormat::gltf, reader, "test");
}

/// One mesh with one primitive, on one node at the origin.
std::string one_primitive(const std::string& primitive, const std::string& node_extra = "") {
    return R"("meshes":[{"primitives":[)" + primitive + R"(]}],"nodes":[{"mesh":0)" + node_extra +
           R"(}],"scenes":[{"nodes":[0]}],"scene":0)";
}

Vec3d normal_of(const TriangleMesh& m, std::size_t t) {
    const Triangle tri = m.triangle(t);
    return cross(tri.b - tri.a, tri.c - tri.a);
}

// A zig-zag strip 0-1-2-3-4 in the z = 0 plane.
const std::vector<float> kStrip = {0, 0, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0, 2, 0, 0};

// glTF 2.0 §3.7.2.1: strip triangle i is (i, i+1, i+2) for even i and (i, i+2, i+1) for odd i,
// so all three triangles keep one winding.
TEST(GltfLoader, TriangleStripAlternatesOrderAndKeepsWinding) {
    Doc d;
    const int pos = d.positions(kStrip);
    auto m = load(d.json(
        one_primitive(R"({"attributes":{"POSITION":)" + std::to_string(pos) + R"(},"mode":5})")));
    ASSERT_TRUE(m.ok()) << m.status().message;
    const TriangleMesh& mesh = m->parts[0].mesh;
    using Tri = std::array<std::uint32_t, 3>;
    ASSERT_EQ(mesh.triangles, (std::vector<Tri>{{0, 1, 2}, {1, 3, 2}, {2, 3, 4}}));
    for (std::size_t t = 0; t < mesh.size(); ++t)
        EXPECT_LT(normal_of(mesh, t).z, 0.0);
}

// Fan triangle i is (i+1, i+2, 0).
TEST(GltfLoader, TriangleFanAroundFirstVertex) {
    Doc d;
    const int pos = d.positions({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, -1, 1, 0});
    auto m = load(d.json(
        one_primitive(R"({"attributes":{"POSITION":)" + std::to_string(pos) + R"(},"mode":6})")));
    ASSERT_TRUE(m.ok()) << m.status().message;
    using Tri = std::array<std::uint32_t, 3>;
    EXPECT_EQ(m->parts[0].mesh.triangles, (std::vector<Tri>{{1, 2, 0}, {2, 3, 0}, {3, 4, 0}}));
}

TEST(GltfLoader, IndexTypesAgree) {
    for (int type : {5121, 5123, 5125}) {
        SCOPED_TRACE(type);
        Doc d;
        const int pos = d.positions(kStrip);
        std::size_t off = 0, len = 0;
        if (type == 5121)
            off = d.add(std::vector<std::uint8_t>{4, 3, 2, 0, 1, 2}), len = 6;
        if (type == 5123)
            off = d.add(std::vector<std::uint16_t>{4, 3, 2, 0, 1, 2}), len = 12;
        if (type == 5125)
            off = d.add(std::vector<std::uint32_t>{4, 3, 2, 0, 1, 2}), len = 24;
        const int idx = d.accessor(d.view(off, len), type, 6, "SCALAR");
        auto m = load(d.json(one_primitive(R"({"attributes":{"POSITION":)" + std::to_string(pos) +
                                           R"(},"indices":)" + std::to_string(idx) + "}")));
        ASSERT_TRUE(m.ok()) << m.status().message;
        using Tri = std::array<std::uint32_t, 3>;
        EXPECT_EQ(m->parts[0].mesh.triangles, (std::vector<Tri>{{4, 3, 2}, {0, 1, 2}}));
    }
}

// POSITION and NORMAL interleaved in one bufferView with byteStride 24.
TEST(GltfLoader, InterleavedAttributesUseByteStride) {
    Doc d;
    const std::size_t off =
        d.add(std::vector<float>{0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 1, 0, 1, 0, 0, 0, 1});
    const int view = d.view(off, 72, 24);
    const int pos = d.accessor(view, 5126, 3, "VEC3", 0);
    const int nrm = d.accessor(view, 5126, 3, "VEC3", 12);
    auto m = load(d.json(one_primitive(R"({"attributes":{"POSITION":)" + std::to_string(pos) +
                                       R"(,"NORMAL":)" + std::to_string(nrm) + "}}")));
    ASSERT_TRUE(m.ok()) << m.status().message;
    const TriangleMesh& mesh = m->parts[0].mesh;
    EXPECT_EQ(mesh.positions, (std::vector<Vec3d>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
    ASSERT_EQ(mesh.normals.size(), 3u);
    EXPECT_EQ(mesh.normals[2], Vec3f(0, 0, 1));
}

// A sparse accessor without a bufferView starts as zeros; values replace elements 1 and 2
// (glTF 2.0 §3.6.2.3).
TEST(GltfLoader, SparseAccessorSubstitutesValues) {
    Doc d;
    const int iv = d.view(d.add(std::vector<std::uint16_t>{1, 2}), 4);
    const int vv = d.view(d.add(std::vector<float>{5, 0, 0, 0, 7, 0}), 24);
    const int pos = d.accessor(
        -1, 5126, 3, "VEC3", 0,
        R"(,"sparse":{"count":2,"indices":{"bufferView":)" + std::to_string(iv) +
            R"(,"componentType":5123},"values":{"bufferView":)" + std::to_string(vv) + "}}");
    auto m =
        load(d.json(one_primitive(R"({"attributes":{"POSITION":)" + std::to_string(pos) + "}}")));
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_EQ(m->parts[0].mesh.positions, (std::vector<Vec3d>{{0, 0, 0}, {5, 0, 0}, {0, 7, 0}}));
}

// KHR_mesh_quantization: normalized shorts decode as c / 32767 (glTF 2.0 §3.11), plain
// unsigned bytes as their value.
TEST(GltfLoader, QuantizedPositions) {
    Doc d;
    const int s = d.accessor(
        d.view(d.add(std::vector<std::int16_t>{0, 0, 0, 0, 32767, 0, 0, 0, 0, -32767, 0, 0}), 24,
               8),
        5122, 3, "VEC3", 0, R"(,"normalized":true)");
    const int b = d.accessor(
        d.view(d.add(std::vector<std::uint8_t>{0, 0, 0, 0, 200, 0, 0, 0, 0, 9, 0, 0}), 12, 4), 5121,
        3, "VEC3");
    auto m = load(d.json(
        R"("extensionsUsed":["KHR_mesh_quantization"],"extensionsRequired":["KHR_mesh_quantization"],)"
        R"("meshes":[{"primitives":[{"attributes":{"POSITION":)" +
        std::to_string(s) + R"(}},{"attributes":{"POSITION":)" + std::to_string(b) +
        R"(}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}])"));
    ASSERT_TRUE(m.ok()) << m.status().message;
    const auto& p = m->parts[0].mesh.positions;
    ASSERT_EQ(p.size(), 6u);
    EXPECT_EQ(p[1], Vec3d(1, 0, 0));
    EXPECT_EQ(p[2], Vec3d(0, -1, 0));
    EXPECT_EQ(p[4], Vec3d(200, 0, 0));
    EXPECT_EQ(p[5], Vec3d(0, 9, 0));
    EXPECT_EQ(m->parts[0].mesh.size(), 2u);
}

TEST(GltfLoader, IndexPastVertexCountIsRejected) {
    Doc d;
    const int pos = d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    const int idx =
        d.accessor(d.view(d.add(std::vector<std::uint16_t>{0, 1, 3, 0}), 6), 5123, 3, "SCALAR");
    auto m = load(d.json(one_primitive(R"({"attributes":{"POSITION":)" + std::to_string(pos) +
                                       R"(},"indices":)" + std::to_string(idx) + "}")));
    ASSERT_FALSE(m.ok());
    EXPECT_EQ(m.status().code, Code::model_load_failed);
    EXPECT_NE(m.status().message.find("out of range"), std::string::npos) << m.status().message;
}

TEST(GltfLoader, AccessorPastItsBufferViewIsRejected) {
    Doc d;
    const int view = d.view(d.add(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}), 36);
    const int pos = d.accessor(view, 5126, 3, "VEC3", 4);  // 4 + 36 > 36
    auto m =
        load(d.json(one_primitive(R"({"attributes":{"POSITION":)" + std::to_string(pos) + "}}")));
    ASSERT_FALSE(m.ok());
    EXPECT_NE(m.status().message.find("/accessors/0"), std::string::npos) << m.status().message;
}

TEST(GltfLoader, BufferViewPastItsBufferIsRejected) {
    Doc d;
    const int view = d.view(d.add(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}), 40);
    d.accessor(view, 5126, 3, "VEC3");
    auto m = load(d.json(one_primitive(R"({"attributes":{"POSITION":0}})")));
    ASSERT_FALSE(m.ok());
    EXPECT_NE(m.status().message.find("/bufferViews/0"), std::string::npos) << m.status().message;
}

TEST(GltfLoader, UnknownRequiredExtensionIsRejected) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    auto m = load(d.json(R"("extensionsRequired":["EXT_from_the_future"],)" +
                         one_primitive(R"({"attributes":{"POSITION":0}})")));
    ASSERT_FALSE(m.ok());
    EXPECT_EQ(m.status().code, Code::model_load_failed);
    EXPECT_NE(m.status().message.find("EXT_from_the_future"), std::string::npos);
}

TEST(GltfLoader, NodeCycleAndSharedChildAreRejected) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    const std::string mesh = R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],)";
    auto cycle = load(d.json(
        mesh + R"("nodes":[{"children":[1]},{"children":[0],"mesh":0}],"scenes":[{"nodes":[0]}])"));
    ASSERT_FALSE(cycle.ok());
    EXPECT_NE(cycle.status().message.find("cycle"), std::string::npos) << cycle.status().message;
    auto self = load(d.json(mesh + R"("nodes":[{"children":[0],"mesh":0}])"));
    ASSERT_FALSE(self.ok());
    auto shared = load(d.json(
        mesh +
        R"("nodes":[{"children":[2]},{"children":[2]},{"mesh":0}],"scenes":[{"nodes":[0,1]}])"));
    ASSERT_FALSE(shared.ok());
    EXPECT_NE(shared.status().message.find("child of both"), std::string::npos);
}

std::string chain(int depth) {
    std::string nodes;
    for (int i = 0; i < depth; ++i) {
        nodes +=
            std::string(i ? "," : "") +
            (i + 1 < depth ? R"({"translation":[1,0,0],"children":[)" + std::to_string(i + 1) + "]}"
                           : R"({"mesh":0})");
    }
    return R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[)" + nodes +
           R"(],"scenes":[{"nodes":[0]}])";
}

TEST(GltfLoader, HierarchyDepthIsBounded) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    auto ok = load(d.json(chain(200)));
    ASSERT_TRUE(ok.ok()) << ok.status().message;
    EXPECT_EQ(ok->parts[0].mesh.positions[0], Vec3d(199, 0, 0));
    auto deep = load(d.json(chain(300)));
    ASSERT_FALSE(deep.ok());
    EXPECT_NE(deep.status().message.find("deeper"), std::string::npos);
}

// A mirroring node (scale −1 in x) reverses each triangle, so the geometric normal of the
// mirrored triangle is the mirror image of the original: +z stays +z.
TEST(GltfLoader, MirroredInstanceKeepsCounterClockwiseFronts) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    auto m =
        load(d.json(one_primitive(R"({"attributes":{"POSITION":0}})", R"(,"scale":[-1,1,1])")));
    ASSERT_TRUE(m.ok());
    const TriangleMesh& mesh = m->parts[0].mesh;
    EXPECT_EQ(mesh.positions[1], Vec3d(-1, 0, 0));
    EXPECT_GT(normal_of(mesh, 0).z, 0.0);
}

TEST(GltfLoader, PointsAndLinesAreSkippedWithWarnings) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    auto m =
        load(d.json(R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"mode":0},)"
                    R"({"attributes":{"POSITION":0},"mode":1},{"attributes":{"POSITION":0}}]}],)"
                    R"("nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}])"));
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_EQ(m->triangle_count(), 1u);
    std::size_t skipped = 0;
    for (const auto& w : m->warnings)
        skipped += w.find("skipped") != std::string::npos;
    EXPECT_EQ(skipped, 2u);
}

// One mesh on three nodes: three parts, each in its own place, named by node, mesh, or the
// display name and the part number.
TEST(GltfLoader, MeshInstancesAreSeparatePartsWithNames) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    auto m = load(d.json(
        R"("meshes":[{"name":"tri","primitives":[{"attributes":{"POSITION":0}}]},)"
        R"({"primitives":[{"attributes":{"POSITION":0}}]}],)"
        R"("nodes":[{"name":"left","mesh":0,"translation":[-5,0,0]},{"mesh":0},{"mesh":1,"translation":[5,0,0]}],)"
        R"("scenes":[{"nodes":[0,1,2]}])"));
    ASSERT_TRUE(m.ok()) << m.status().message;
    ASSERT_EQ(m->parts.size(), 3u);
    EXPECT_EQ(m->parts[0].name, "left");
    EXPECT_EQ(m->parts[1].name, "tri");
    EXPECT_EQ(m->parts[2].name, "test mesh 3");
    EXPECT_EQ(m->parts[0].mesh.positions[1], Vec3d(-4, 0, 0));
    EXPECT_EQ(m->parts[2].mesh.positions[1], Vec3d(6, 0, 0));
}

// Metallic-roughness → Phong (glTF 2.0 Appendix B): diffuse = base·(1 − metallic), specular =
// mix(0.04, base, metallic) of which base·metallic is textured, ambient = 0.1·base, shininess =
// 2/roughness⁴ − 2; a primitive without a material gets an appended default.
TEST(GltfLoader, MaterialsMapToPhong) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    auto m = load(d.json(
        R"("materials":[{"name":"half","pbrMetallicRoughness":{"baseColorFactor":[0.5,0.25,1,1],)"
        R"("metallicFactor":0.5,"roughnessFactor":0.5},"emissiveFactor":[1,0,0]}],)"
        R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"material":0},{"attributes":{"POSITION":0}}]}],)"
        R"("nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}])"));
    ASSERT_TRUE(m.ok()) << m.status().message;
    ASSERT_EQ(m->materials.size(), 2u);
    const Material& mat = m->materials[0];
    EXPECT_EQ(mat.diffuse, Vec3d(0.25, 0.125, 0.5));
    EXPECT_EQ(mat.ambient, Vec3d(0.05, 0.025, 0.1));
    EXPECT_EQ(mat.textured_specular, Vec3d(0.25, 0.125, 0.5));
    EXPECT_NEAR(mat.specular.x, 0.5 * 0.04 + 0.5 * 0.5, 1e-15);
    EXPECT_NEAR(mat.specular.z, 0.5 * 0.04 + 0.5 * 1.0, 1e-15);
    EXPECT_NEAR(mat.shininess, 30.0, 1e-12);
    EXPECT_EQ(mat.emissive, Vec3d(1, 0, 0));
    EXPECT_EQ(m->material_names, (std::vector<std::string>{"half", "default"}));
    EXPECT_EQ(m->parts[0].mesh.triangle_material, (std::vector<std::uint32_t>{0, 1}));
}

// glTF's default material (metallic 1, roughness 1) is a rough metal: no diffuse, its base
// colour all in the specular (it had been both, and a head-on textured Cube.gltf came out
// white); and an emissive factor over an emissiveTexture, which is not read, is left out with a
// warning rather than lighting the whole surface.
TEST(GltfLoader, DefaultMetalHasNoDiffuseAndAnUnreadEmissiveTextureNoGlow) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    auto m = load(d.json(
        R"("materials":[{"pbrMetallicRoughness":{"baseColorFactor":[1,0.5,0.25,1]}},)"
        R"({"emissiveFactor":[1,1,1],"emissiveTexture":{"index":0}},{"emissiveFactor":[1,0,0]}],)"
        R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"material":0}]}],)"
        R"("nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}])"));
    ASSERT_TRUE(m.ok()) << m.status().message;
    ASSERT_EQ(m->materials.size(), 3u);
    const Material& metal = m->materials[0];
    EXPECT_EQ(metal.diffuse, Vec3d(0, 0, 0));
    EXPECT_EQ(metal.specular, Vec3d(1, 0.5, 0.25));
    EXPECT_EQ(metal.textured_specular, Vec3d(1, 0.5, 0.25));
    EXPECT_EQ(metal.ambient, Vec3d(0.1, 0.05, 0.025));
    EXPECT_EQ(metal.shininess, 1.0);
    EXPECT_EQ(m->materials[1].emissive, Vec3d(0, 0, 0));
    EXPECT_EQ(m->materials[2].emissive, Vec3d(1, 0, 0));
    int unread = 0;
    for (const std::string& w : m->warnings)
        unread += w == "/materials/1: its emissiveTexture is not read, so its emission is left out";
    EXPECT_EQ(unread, 1);
}

// A metallicRoughnessTexture is not sampled per hit: the means of its B (metallic) and G
// (roughness) channels, linear, multiply the factors. Here B averages 0.5 and G 64/255 over two
// texels, so the default factors (1) give a half-metal; an image that cannot be decoded leaves
// the factors alone, with a warning.
TEST(GltfLoader, AMetallicRoughnessTextureScalesTheFactorsByItsMean) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    const std::vector<std::uint8_t> texels = {0, 128, 255, 0, 0, 0};
    auto m = load(d.json(
        R"("materials":[{"pbrMetallicRoughness":{"metallicRoughnessTexture":{"index":0}}},)"
        R"({"pbrMetallicRoughness":{"metallicRoughnessTexture":{"index":1}}}],)"
        R"("textures":[{"source":0},{"source":1}],"images":[{"uri":"data:image/png;base64,)" +
        base64(testing::png(2, 1, texels)) +
        R"("},{"uri":"data:image/png;base64,AAAA"}],)"
        R"("meshes":[{"primitives":[{"attributes":{"POSITION":0},"material":0}]}],)"
        R"("nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}])"));
    ASSERT_TRUE(m.ok()) << m.status().message;
    const Material& half = m->materials[0];
    EXPECT_EQ(half.diffuse, Vec3d(0.5, 0.5, 0.5));
    EXPECT_EQ(half.textured_specular, Vec3d(0.5, 0.5, 0.5));
    const double r = 64.0 / 255.0;
    EXPECT_NEAR(half.shininess, 2.0 / (r * r * r * r) - 2.0, 1e-9);
    EXPECT_EQ(m->materials[1].diffuse, Vec3d(0, 0, 0));  // metallic 1: the factor alone
    bool warned = false;
    for (const std::string& w : m->warnings)
        warned =
            warned || w.find("uses its metallic and roughness factors alone") != std::string::npos;
    EXPECT_TRUE(warned);
}

// A morph target at weight 0.5 moves the rest pose halfway (glTF 2.0 §3.7.2.2).
TEST(GltfLoader, MorphTargetsAtDefaultWeights) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    d.positions({0, 0, 2, 0, 0, 2, 0, 0, 2});
    auto m = load(d.json(
        R"("meshes":[{"weights":[0.5],"primitives":[{"attributes":{"POSITION":0},"targets":[{"POSITION":1}]}]}],)"
        R"("nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}])"));
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_EQ(m->parts[0].mesh.positions[1], Vec3d(1, 0, 1));
}

TEST(GltfLoader, LightsAndCameraFromNodes) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    // Node 2 is turned +90° about y (quaternion (0, sin 45°, 0, cos 45°)): its −Z looks along −X.
    auto m = load(d.json(
        R"("extensionsUsed":["KHR_lights_punctual"],"extensions":{"KHR_lights_punctual":{"lights":[)"
        R"({"type":"point","color":[1,0.5,0],"intensity":4},{"type":"directional","intensity":2}]}},)"
        R"("cameras":[{"type":"perspective","perspective":{"yfov":0.5,"znear":0.1}}],)"
        R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],)"
        R"("nodes":[{"mesh":0},{"translation":[1,2,3],"extensions":{"KHR_lights_punctual":{"light":0}}},)"
        R"({"rotation":[0,0.7071067811865476,0,0.7071067811865476],"camera":0,"extensions":{"KHR_lights_punctual":{"light":1}}}],)"
        R"("scenes":[{"nodes":[0,1,2]}])"));
    ASSERT_TRUE(m.ok()) << m.status().message;
    ASSERT_EQ(m->lights.size(), 2u);
    EXPECT_EQ(m->lights[0].type, LightType::point);
    EXPECT_EQ(m->lights[0].position, Vec3d(1, 2, 3));
    // Colour × intensity, rescaled together so the brightest component is 1: (4, 2, 0) / 4.
    EXPECT_EQ(m->lights[0].intensity, Vec3d(1, 0.5, 0));
    EXPECT_EQ(m->lights[1].type, LightType::directional);
    EXPECT_NEAR(m->lights[1].direction.x, -1.0, 1e-12);
    EXPECT_EQ(m->lights[1].intensity, Vec3d(0.5, 0.5, 0.5));
    ASSERT_TRUE(m->camera);
    EXPECT_NEAR(m->camera->fov_y_deg, 0.5 * 180 / 3.14159265358979323846, 1e-12);
    EXPECT_NEAR(m->camera->look_at.x, -1.0, 1e-12);
    EXPECT_NEAR(m->camera->up.y, 1.0, 1e-12);
}

TEST(GltfLoader, ACameraWithoutAViewIsDroppedWithAWarning) {
    // Placed 1e17 out, its look_at one unit ahead rounds onto its position; by a matrix that
    // sends its local y and z both along world z, its up is parallel to its view. Neither has
    // a view to render (the scene document's camera rules): each is dropped with a warning,
    // and a later usable camera is taken.
    for (const char* node : {R"({"translation":[0,0,1e17],"camera":0})",
                             R"({"matrix":[1,0,0,0, 0,0,1,0, 0,0,1,0, 0,0,0,1],"camera":0})"}) {
        Doc d;
        d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
        auto m = load(d.json(std::string(R"("cameras":[{"type":"perspective","perspective":)"
                                         R"({"yfov":0.5,"znear":0.1}}],)"
                                         R"("meshes":[{"primitives":[{"attributes":)"
                                         R"({"POSITION":0}}]}],"nodes":[{"mesh":0},)") +
                             node + R"(,{"translation":[0,0,5],"camera":0}],)" +
                             R"("scenes":[{"nodes":[0,1,2]}])"));
        ASSERT_TRUE(m.ok()) << m.status().message;
        ASSERT_TRUE(m->camera) << node;
        EXPECT_EQ(m->camera->position, Vec3d(0, 0, 5)) << node;
        ASSERT_EQ(m->warnings.size(), 1u) << node;
        EXPECT_NE(m->warnings[0].find("/nodes/1: its camera has no view"), std::string::npos)
            << m->warnings[0];
    }
}

TEST(GltfLoader, UnresolvedLightIsRejected) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    auto m = load(d.json(one_primitive(R"({"attributes":{"POSITION":0}})",
                                       R"(,"extensions":{"KHR_lights_punctual":{"light":3}})")));
    ASSERT_FALSE(m.ok());
}

// External buffers come through the ResourceReader, and only buffers: the image is never
// requested, and an http: buffer is refused before the reader is asked.
TEST(GltfLoader, ExternalBufferThroughReaderOnly) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    std::map<std::string, int> asked;
    ResourceReader reader = [&](const std::string& uri) -> Result<std::string> {
        ++asked[uri];
        if (uri == "sub dir/tri.bin")
            return d.bin();
        return Status::error(Code::not_found, uri);
    };
    const std::string rest =
        R"("images":[{"uri":"tex.png"}],)" + one_primitive(R"({"attributes":{"POSITION":0}})");
    auto m = load(d.json(rest, "sub%20dir/tri.bin"), reader);
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_EQ(m->triangle_count(), 1u);
    EXPECT_EQ(asked, (std::map<std::string, int>{{"sub dir/tri.bin", 1}}));
    asked.clear();
    auto http = load(d.json(rest, "http://example.com/tri.bin"), reader);
    ASSERT_FALSE(http.ok());
    EXPECT_TRUE(asked.empty());
    EXPECT_NE(http.status().message.find("scheme"), std::string::npos) << http.status().message;
    auto missing = load(d.json(rest, "gone.bin"), reader);
    ASSERT_FALSE(missing.ok());
    EXPECT_NE(missing.status().message.find("gone.bin"), std::string::npos);
}

// A data URI that decodes to fewer bytes than byteLength claims is refused.
TEST(GltfLoader, ByteLengthThatLiesIsRejected) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    std::string json = d.json(one_primitive(R"({"attributes":{"POSITION":0}})"));
    const std::string from = R"("byteLength":36,"uri")";
    json.replace(json.find(from), from.size(), R"("byteLength":40,"uri")");
    EXPECT_FALSE(load(json).ok());
}

std::string glb(const std::string& json, const std::string& bin, std::uint32_t version = 2) {
    std::string j = json, b = bin;
    while (j.size() % 4)
        j += ' ';
    while (b.size() % 4)
        b += '\0';
    auto u32 = [](std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
    const auto total =
        static_cast<std::uint32_t>(12 + 8 + j.size() + (b.empty() ? 0 : 8 + b.size()));
    std::string out =
        "glTF" + u32(version) + u32(total) + u32(static_cast<std::uint32_t>(j.size())) + "JSON" + j;
    if (!b.empty())
        out += u32(static_cast<std::uint32_t>(b.size())) + std::string("BIN\0", 4) + b;
    return out;
}

TEST(GltfLoader, GlbContainerChecks) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    std::string json = d.json(one_primitive(R"({"attributes":{"POSITION":0}})"));
    json.replace(json.find(R"(,"uri")"),
                 json.find("}]", json.find(R"(,"uri")")) - json.find(R"(,"uri")"), "");
    const std::string good = glb(json, d.bin());
    auto ok = load_model(good, ModelFormat::glb, no_resources(), "t.glb");
    ASSERT_TRUE(ok.ok()) << ok.status().message;
    EXPECT_EQ(ok->triangle_count(), 1u);
    // Every truncation is refused without reading past the end.
    for (std::size_t n : std::vector<std::size_t>{0, 11, 12, 19, 20, 40, good.size() - 1}) {
        EXPECT_FALSE(load_model(good.substr(0, n), ModelFormat::glb, no_resources(), "t").ok())
            << n;
    }
    auto v1 = load_model(glb(json, d.bin(), 1), ModelFormat::glb, no_resources(), "t");
    ASSERT_FALSE(v1.ok());
    EXPECT_EQ(v1.status().code, Code::unsupported_format);
    // A BIN chunk whose length would end inside its own 8-byte header's reach past the file.
    std::string lying = good;
    const std::size_t bin_len_at = 12 + 8 + (lying[12] & 0xFF) + ((lying[13] & 0xFF) << 8);
    lying[bin_len_at] = static_cast<char>(lying[bin_len_at] + 4);
    EXPECT_FALSE(load_model(lying, ModelFormat::glb, no_resources(), "t").ok());
    // An unknown chunk after BIN is ignored (glTF 2.0 §4.4.3).
    std::string extra = good + std::string("\4\0\0\0XTRA\0\0\0\0", 12);
    const auto len = static_cast<std::uint32_t>(extra.size());
    std::memcpy(&extra[8], &len, 4);
    EXPECT_TRUE(load_model(extra, ModelFormat::glb, no_resources(), "t").ok());
}

// A byteLength of a petabyte is refused without being allocated: buffers are sized from the
// bytes present (under ASan an allocation that size would abort the test), in a data: URI, a
// GLB's BIN chunk and an external file alike.
TEST(GltfLoader, HugeByteLengthIsRefusedBeforeAnyAllocation) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    const std::string json = d.json(one_primitive(R"({"attributes":{"POSITION":0}})"));
    const std::string from = R"("byteLength":36,"uri")";
    const std::string huge = R"("byteLength":1000000000000000,"uri")";
    std::string data_uri = json;
    data_uri.replace(data_uri.find(from), from.size(), huge);
    auto a = load(data_uri);
    ASSERT_FALSE(a.ok());
    EXPECT_EQ(a.status().code, Code::model_load_failed);

    std::string bin_json = json;
    const std::size_t uri = bin_json.find(R"(,"uri")");
    bin_json.replace(uri, bin_json.find("}]", uri) - uri, "");
    bin_json.replace(bin_json.find(R"("byteLength":36)"), 15, R"("byteLength":1000000000000000)");
    EXPECT_FALSE(
        load_model(glb(bin_json, d.bin()), ModelFormat::glb, no_resources(), "t.glb").ok());
}

// glTF 2.0 §3.7.3.3: vertex v moves by Σ w·(global(joint)·inverseBind); the skinned node's own
// transform (here a translation by 9) plays no part.
TEST(GltfLoader, SkinnedMeshIsPosedByItsJoints) {
    Doc d;
    const int pos = d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    const std::vector<std::uint8_t> joints = {0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0};
    const int j = d.accessor(d.view(d.add(joints), joints.size()), 5121, 3, "VEC4");
    // Vertex 0: all on joint 0; vertex 1: half joint 0, half joint 1; vertex 2: no weight.
    const std::vector<float> weights = {1, 0, 0, 0, 0.5f, 0.5f, 0, 0, 0, 0, 0, 0};
    const int w = d.accessor(d.view(d.add(weights), weights.size() * 4), 5126, 3, "VEC4");
    auto m =
        load(d.json(R"("meshes":[{"primitives":[{"attributes":{"POSITION":)" + std::to_string(pos) +
                    R"(,"JOINTS_0":)" + std::to_string(j) + R"(,"WEIGHTS_0":)" + std::to_string(w) +
                    R"(}}]}],)"
                    R"("skins":[{"joints":[1,2]}],)"
                    R"("nodes":[{"mesh":0,"skin":0,"translation":[9,9,9]},)"
                    R"({"translation":[0,5,0]},{"translation":[0,0,4]}],)"
                    R"("scenes":[{"nodes":[0,1,2]}])"));
    ASSERT_TRUE(m.ok()) << m.status().message;
    const auto& p = m->parts[0].mesh.positions;
    EXPECT_EQ(p[0], Vec3d(0, 5, 0));
    EXPECT_EQ(p[1], Vec3d(1, 2.5, 2));
    EXPECT_EQ(p[2], Vec3d(0, 1, 0));  // no weight: its bind pose
    EXPECT_TRUE(m->warnings.empty()) << m->warnings[0];
}

// An inverse bind matrix undoes the joint's bind placement: a joint still where it was bound
// leaves the mesh where it is.
TEST(GltfLoader, InverseBindMatricesCancelTheBindPose) {
    Doc d;
    const int pos = d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    const std::vector<std::uint8_t> joints(12, 0);
    const int j = d.accessor(d.view(d.add(joints), joints.size()), 5121, 3, "VEC4");
    const std::vector<float> weights = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
    const int w = d.accessor(d.view(d.add(weights), weights.size() * 4), 5126, 3, "VEC4");
    const std::vector<float> ibm = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -3, 0, 0, 1};
    const int b = d.accessor(d.view(d.add(ibm), ibm.size() * 4), 5126, 1, "MAT4");
    const std::string doc = d.json(
        R"("meshes":[{"primitives":[{"attributes":{"POSITION":)" + std::to_string(pos) +
        R"(,"JOINTS_0":)" + std::to_string(j) + R"(,"WEIGHTS_0":)" + std::to_string(w) +
        R"(}}]}],"skins":[{"joints":[1],"inverseBindMatrices":)" + std::to_string(b) +
        R"(}],"nodes":[{"mesh":0,"skin":0},{"translation":[3,0,0]}],"scenes":[{"nodes":[0,1]}])");
    auto m = load(doc);
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_EQ(m->parts[0].mesh.positions[1], Vec3d(1, 0, 0));
    // A vertex naming a joint the skin does not have is refused (glTF-Validator:
    // ACCESSOR_JOINTS_INDEX_OOB).
    std::string bad = doc;
    bad.replace(bad.find(R"("joints":[1])"), 12, R"("joints":[])");
    EXPECT_FALSE(load(bad).ok());
}

/// A texture document: a 2 × 2 image (red, green / blue, white) as `image` (the JSON of
/// /images/0), on material 0 with `texture_info` extra members, a triangle with TEXCOORD_0
/// (0,0), (1,0), (0,1) and TEXCOORD_1 all (0.75, 0.75).
std::string textured_doc(Doc& d, const std::string& image, const std::string& texture_info = "",
                         const std::string& sampler = "{}") {
    const int pos = d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    const std::vector<float> uv0 = {0, 0, 1, 0, 0, 1},
                             uv1 = {0.75f, 0.75f, 0.75f, 0.75f, 0.75f, 0.75f};
    const int t0 = d.accessor(d.view(d.add(uv0), 24), 5126, 3, "VEC2");
    const int t1 = d.accessor(d.view(d.add(uv1), 24), 5126, 3, "VEC2");
    return d.json(R"("meshes":[{"primitives":[{"attributes":{"POSITION":)" + std::to_string(pos) +
                  R"(,"TEXCOORD_0":)" + std::to_string(t0) + R"(,"TEXCOORD_1":)" +
                  std::to_string(t1) +
                  R"(},"material":0}]}],)"
                  R"("materials":[{"pbrMetallicRoughness":{"baseColorFactor":[1,1,0.5,1],)"
                  R"("baseColorTexture":{"index":0)" +
                  texture_info +
                  R"(}}}],)"
                  R"("textures":[{"source":0,"sampler":0}],"samplers":[)" +
                  sampler +
                  "],"
                  R"("images":[)" +
                  image + R"(],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}])");
}

const std::vector<std::uint8_t> kQuad = {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255};

TEST(GltfLoader, BaseColorTextureFromADataUri) {
    Doc d;
    const std::string image =
        R"({"uri":"data:image/png;base64,)" + base64(testing::png(2, 2, kQuad)) + R"("})";
    auto m = load(textured_doc(d, image, "", R"({"magFilter":9728,"wrapS":33071,"wrapT":33648})"));
    ASSERT_TRUE(m.ok()) << m.status().message;
    ASSERT_TRUE(m->warnings.empty()) << m->warnings[0];
    const Material& mat = m->materials[0];
    ASSERT_TRUE(mat.texture);
    // The factor stays and the texel multiplies it: with glTF's default metallic 1, as the
    // specular colour's base-colour share (the diffuse is zero).
    EXPECT_EQ(mat.textured_specular, Vec3d(1, 1, 0.5));
    EXPECT_EQ(mat.diffuse, Vec3d(0, 0, 0));
    EXPECT_EQ(mat.texture->image->width, 2);
    EXPECT_EQ(mat.texture->image->rgb, kQuad);
    EXPECT_TRUE(mat.texture->nearest);
    EXPECT_EQ(mat.texture->wrap_s, TextureWrap::clamp_to_edge);
    EXPECT_EQ(mat.texture->wrap_t, TextureWrap::mirrored_repeat);
    const auto& uv = m->parts[0].mesh.corner_uvs;
    ASSERT_EQ(uv.size(), 1u);
    using Corner = std::array<float, 2>;
    EXPECT_EQ(uv[0][1], (Corner{1, 0}));
    EXPECT_EQ(uv[0][2], (Corner{0, 1}));
    // Texel (0, 0) is red: the image's first row, first texel.
    EXPECT_EQ(mat.texture->sample(0.25, 0.25), Vec3d(1, 0, 0));
    EXPECT_EQ(mat.texture->sample(0.25, 0.75), Vec3d(0, 0, 1));
}

TEST(GltfLoader, TextureTransformAndTexCoordSet) {
    Doc d;
    const std::string image =
        R"({"uri":"data:image/png;base64,)" + base64(testing::png(2, 2, kQuad)) + R"("})";
    // KHR_texture_transform: u' = sx·u + ox, v' = sy·v + oy without rotation.
    auto m = load(textured_doc(
        d, image,
        R"(,"extensions":{"KHR_texture_transform":{"offset":[0.5,0.25],"scale":[0.5,2]}})"));
    ASSERT_TRUE(m.ok()) << m.status().message;
    using Corner = std::array<float, 2>;
    const auto& uv = m->parts[0].mesh.corner_uvs;
    ASSERT_EQ(uv.size(), 1u);
    EXPECT_EQ(uv[0][0], (Corner{0.5f, 0.25f}));
    EXPECT_EQ(uv[0][1], (Corner{1.0f, 0.25f}));
    EXPECT_EQ(uv[0][2], (Corner{0.5f, 2.25f}));
    // A rotation by π/2 maps (1, 0) to (cos, −sin) = (0, −1); texCoord 1 picks TEXCOORD_1.
    Doc d2;
    auto r = load(textured_doc(
        d2, image, R"(,"extensions":{"KHR_texture_transform":{"rotation":1.5707963267948966}})"));
    ASSERT_TRUE(r.ok()) << r.status().message;
    EXPECT_NEAR(r->parts[0].mesh.corner_uvs[0][1][0], 0.0f, 1e-7f);
    EXPECT_NEAR(r->parts[0].mesh.corner_uvs[0][1][1], -1.0f, 1e-7f);
    Doc d3;
    auto s = load(textured_doc(d3, image, R"(,"texCoord":1)"));
    ASSERT_TRUE(s.ok()) << s.status().message;
    EXPECT_EQ(s->parts[0].mesh.corner_uvs[0][1], (Corner{0.75f, 0.75f}));
}

TEST(GltfLoader, TextureImagesFromABufferViewAndFromAFile) {
    const std::string png = testing::png(2, 2, kQuad);
    Doc d;
    const int view = d.view(d.add(std::vector<char>(png.begin(), png.end())), png.size());
    auto m = load(textured_doc(
        d, R"({"bufferView":)" + std::to_string(view) + R"(,"mimeType":"image/png"})"));
    ASSERT_TRUE(m.ok()) << m.status().message;
    ASSERT_TRUE(m->materials[0].texture);
    EXPECT_EQ(m->materials[0].texture->image->rgb, kQuad);

    std::vector<std::string> asked;
    ResourceReader files = [&](const std::string& uri) -> Result<std::string> {
        asked.push_back(uri);
        if (uri == "tex dir/a b.png")
            return png;
        return Status::error(Code::not_found, uri + " not found");
    };
    Doc d2;
    auto f = load(textured_doc(d2, R"({"uri":"tex%20dir/a%20b.png"})"), files);
    ASSERT_TRUE(f.ok()) << f.status().message;
    ASSERT_TRUE(f->materials[0].texture) << (f->warnings.empty() ? "" : f->warnings[0]);
    EXPECT_EQ(f->materials[0].texture->image->rgb, kQuad);
    EXPECT_EQ(asked, std::vector<std::string>{"tex dir/a b.png"});
    // Outside the model's directory tree: refused before the reader is asked.
    Doc d3;
    asked.clear();
    auto out = load(textured_doc(d3, R"({"uri":"/etc/passwd"})"), files);
    ASSERT_TRUE(out.ok()) << out.status().message;
    EXPECT_FALSE(out->materials[0].texture);
    EXPECT_TRUE(asked.empty());
}

// A texture that cannot be used costs the texture, never the model: a warning, and the
// material keeps its factor alone.
TEST(GltfLoader, UnusableTexturesAreWarnings) {
    struct Case {
        std::string what, image, expect;
        std::size_t max_pixels = 1u << 24, max_total = 1u << 26;
    };
    const std::string png = testing::png(2, 2, kQuad);
    std::string truncated = png.substr(0, 40);
    const std::vector<Case> cases = {
        {"missing file", R"({"uri":"nowhere.png"})", "nowhere.png"},
        {"not an image", R"({"uri":"data:image/png;base64,)" + base64("GIF89a......") + R"("})",
         "not a PNG or JPEG"},
        {"truncated", R"({"uri":"data:image/png;base64,)" + base64(truncated) + R"("})",
         "does not decode"},
        {"over the pixel limit", R"({"uri":"data:image/png;base64,)" + base64(png) + R"("})",
         "--max-texture-pixels", 3},
        // Within the one-image limit, past what the model's images may take together.
        {"over the model's total", R"({"uri":"data:image/png;base64,)" + base64(png) + R"("})",
         "together", 16, 3},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.what);
        Doc d;
        LoadLimits limits;
        limits.max_texture_pixels = c.max_pixels;
        limits.max_texture_pixels_total = c.max_total;
        auto m =
            load_model(textured_doc(d, c.image), ModelFormat::gltf, no_resources(), "t", limits);
        ASSERT_TRUE(m.ok()) << m.status().message;
        EXPECT_FALSE(m->materials[0].texture);
        ASSERT_EQ(m->warnings.size(), 1u);
        EXPECT_NE(m->warnings[0].find(c.expect), std::string::npos) << m->warnings[0];
        EXPECT_NE(m->warnings[0].find("base colour alone"), std::string::npos) << m->warnings[0];
    }
}

// The model's images share the scene's texture budget, base colours first: with room for one
// 2×2 image, the base-colour texture is decoded and the metallic-roughness map (listed first)
// is the one refused, its factors standing alone.
TEST(GltfLoader, BaseColourTexturesComeFirstInTheBudget) {
    Doc d;
    const std::string png = base64(testing::png(2, 2, kQuad));
    std::string doc = textured_doc(d, R"({"uri":"data:image/png;base64,)" + png + R"("})");
    // The material gains a metallicRoughnessTexture of its own image, listed before the base's.
    const std::string base_ref = R"("baseColorTexture":{"index":0)";
    doc.replace(doc.find(base_ref), base_ref.size(),
                R"("metallicRoughnessTexture":{"index":1},"baseColorTexture":{"index":0)");
    doc.replace(doc.find(R"("textures":[)"), std::string(R"("textures":[)").size(),
                R"("textures":[{"source":0},)");
    doc.replace(doc.find(R"("source":0,"sampler":0)"),
                std::string(R"("source":0,"sampler":0)").size(), R"("source":1,"sampler":0)");
    doc.replace(doc.find(R"("images":[)"), std::string(R"("images":[)").size(),
                R"("images":[{"uri":"data:image/png;base64,)" + png + R"("},)");
    LoadLimits limits;
    limits.max_texture_pixels_total = 4;
    auto m = load_model(doc, ModelFormat::gltf, no_resources(), "t", limits);
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_TRUE(m->materials[0].texture);
    bool refused = false;
    for (const std::string& w : m->warnings)
        refused = refused || w.find("metallic and roughness factors alone") != std::string::npos;
    EXPECT_TRUE(refused);
}

TEST(GltfLoader, TriangleLimitIsEnforced) {
    Doc d;
    d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    LoadLimits limits;
    limits.max_triangles = 1;
    auto m = load_model(d.json(R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],)"
                               R"("nodes":[{"mesh":0},{"mesh":0}],"scenes":[{"nodes":[0,1]}])"),
                        ModelFormat::gltf, no_resources(), "t", limits);
    ASSERT_FALSE(m.ok());
    EXPECT_EQ(m.status().code, Code::too_large);
}

}  // namespace
}  // namespace raycastd::engine
