// OBJ/MTL, PLY, STL and OFF readers on small inline files, format naming and sniffing,
// apply_transform, and a deterministic mutation pass that feeds damaged files to every reader.

#include <cstring>
#include <random>

#include <gtest/gtest.h>

#include "engine/load/model_loader.h"
#include "engine/testing/png.h"

namespace raycastd::engine {
namespace {

using Tri = std::array<std::uint32_t, 3>;

Result<LoadedModel> load(std::string_view bytes, ModelFormat f,
                         const ResourceReader& reader = no_resources()) {
    return load_model(bytes, f, reader, "m");
}

TEST(FormatNames, FromNameAndExtension) {
    EXPECT_EQ(format_from_name("glb"), ModelFormat::glb);
    EXPECT_EQ(format_from_name("GLTF"), ModelFormat::gltf);
    EXPECT_EQ(format_from_name("models/Duck/glTF-Binary/Duck.GLB"), ModelFormat::glb);
    EXPECT_EQ(format_from_name("featuretype.STL"), ModelFormat::stl);
    EXPECT_EQ(format_from_name("a.b.off"), ModelFormat::off);
    EXPECT_EQ(format_from_name("x.ply"), ModelFormat::ply);
    EXPECT_EQ(format_from_name("Obj"), ModelFormat::obj);
    EXPECT_EQ(format_from_name("model.fbx"), std::nullopt);
    EXPECT_EQ(format_from_name(""), std::nullopt);
    EXPECT_EQ(format_name(ModelFormat::stl), "stl");
}

std::string binary_stl(const std::string& header, const std::vector<std::array<float, 9>>& tris) {
    std::string out = header;
    out.resize(80, ' ');
    const auto n = static_cast<std::uint32_t>(tris.size());
    out.append(reinterpret_cast<const char*>(&n), 4);
    for (const auto& t : tris) {
        out.append(12, '\0');  // facet normal, ignored
        out.append(reinterpret_cast<const char*>(t.data()), 36);
        out.append(2, '\0');
    }
    return out;
}

TEST(FormatNames, Sniffing) {
    EXPECT_EQ(sniff_format(std::string("glTF\2\0\0\0", 8)), ModelFormat::glb);
    EXPECT_EQ(sniff_format(" \n{\"asset\":{}}"), ModelFormat::gltf);
    EXPECT_EQ(sniff_format("\xEF\xBB\xBF{}"), ModelFormat::gltf);
    EXPECT_EQ(sniff_format("ply\nformat ascii 1.0\n"), ModelFormat::ply);
    EXPECT_EQ(sniff_format("ply\r\nformat ascii 1.0\r\n"), ModelFormat::ply);
    EXPECT_EQ(sniff_format("OFF\n3 1 0\n"), ModelFormat::off);
    EXPECT_EQ(sniff_format("CNOFF 3 1 0\n"), ModelFormat::off);
    EXPECT_EQ(sniff_format("solid cube\nfacet normal 0 0 1\n"), ModelFormat::stl);
    EXPECT_EQ(sniff_format("SOLID x\n"), ModelFormat::stl);
    // Binary STL whose header starts with "solid": the size rule wins.
    const std::string b = binary_stl("solid but binary", {{0, 0, 0, 1, 0, 0, 0, 1, 0}});
    EXPECT_EQ(b.size(), 134u);
    EXPECT_EQ(sniff_format(b), ModelFormat::stl);
    EXPECT_EQ(sniff_format(binary_stl("exported", {})), ModelFormat::stl);
    EXPECT_EQ(sniff_format("v 1 2 3\nf 1 1 1\n"), std::nullopt);
    EXPECT_EQ(sniff_format(""), std::nullopt);
    EXPECT_EQ(sniff_format("gl"), std::nullopt);
}

// Polygons are fanned as (v0, vi, vi+1) in file order; negative indices count back from the
// latest vertex; v/vt/vn corners are accepted.
TEST(ObjReader, FansNegativeIndicesAndCorners) {
    auto m = load(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\n"
        "f 1//1 2//1 3//1 4//1\n"
        "f -4/1/1 -2/2/1 -1/3/1\n",
        ModelFormat::obj);
    ASSERT_TRUE(m.ok()) << m.status().message;
    const TriangleMesh& mesh = m->parts[0].mesh;
    EXPECT_EQ(mesh.triangles, (std::vector<Tri>{{0, 1, 2}, {0, 2, 3}, {0, 2, 3}}));
    ASSERT_EQ(mesh.normals.size(), 4u);
    EXPECT_EQ(mesh.normals[3], Vec3f(0, 0, 1));
    EXPECT_EQ(m->parts[0].name, "m");
    EXPECT_TRUE(mesh.triangle_material.empty());
}

TEST(ObjReader, BadIndicesAreErrorsNotDroppedFaces) {
    for (const char* obj :
         {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
          "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -1 1\n", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n"}) {
        SCOPED_TRACE(obj);
        auto m = load(obj, ModelFormat::obj);
        ASSERT_FALSE(m.ok());
        EXPECT_EQ(m.status().code, Code::model_load_failed);
        EXPECT_NE(m.status().message.find("line 4"), std::string::npos) << m.status().message;
    }
}

// usemtl names resolve against the mtllib read through the ResourceReader (Windows separators
// turned into '/'); triangles before any usemtl get an appended default material.
TEST(ObjReader, MaterialsFromMtlThroughReader) {
    std::vector<std::string> asked;
    ResourceReader reader = [&](const std::string& uri) -> Result<std::string> {
        asked.push_back(uri);
        if (uri == "mats/a b.mtl") {
            return std::string(
                "newmtl red\nKd 1 0 0\nKs 0.5 0.5 0.5\nNs 64\nd 0.25\n"
                "newmtl grey\nKd 0.5\nKa 0.2 0.2 0.2\n");
        }
        return Status::error(Code::not_found, uri);
    };
    auto m = load(
        "mtllib mats\\a b.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl grey\nf 1 2 3\n"
        "usemtl red\nf 1 2 3\nusemtl nowhere\nf 1 2 3\n",
        ModelFormat::obj, reader);
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_EQ(asked, (std::vector<std::string>{"mats/a b.mtl"}));
    EXPECT_EQ(m->material_names, (std::vector<std::string>{"grey", "red", "nowhere", "default"}));
    EXPECT_EQ(m->parts[0].mesh.triangle_material, (std::vector<std::uint32_t>{3, 0, 1, 2}));
    const Material& red = m->materials[1];
    EXPECT_EQ(red.diffuse, Vec3d(1, 0, 0));
    EXPECT_EQ(red.ambient, Vec3d(0.1, 0, 0));  // no Ka: 0.1·Kd
    EXPECT_EQ(red.specular, Vec3d(0.5, 0.5, 0.5));
    EXPECT_EQ(red.shininess, 64.0);
    EXPECT_EQ(red.transparency, 0.75);
    EXPECT_EQ(m->materials[0].diffuse, Vec3d(0.5, 0.5, 0.5));
    EXPECT_EQ(m->materials[0].ambient, Vec3d(0.2, 0.2, 0.2));
    EXPECT_FALSE(m->warnings.empty());  // "nowhere" is not defined
}

// map_Kd through the reader, relative to the MTL's own directory; OBJ's v runs up, ours down
// (v ↦ 1 − v, after the map's -s scale and -o offset); -clamp on clamps both axes. The second
// material has no map, and its faces get (0, 0) corners.
TEST(ObjReader, DiffuseMapsAndTextureCoordinates) {
    const std::string png = testing::png(2, 1, {255, 0, 0, 0, 0, 255});
    std::vector<std::string> asked;
    ResourceReader reader = [&](const std::string& uri) -> Result<std::string> {
        asked.push_back(uri);
        if (uri == "m/a.mtl")
            return std::string(
                "newmtl tex\nKd 1 1 1\nmap_Kd -s 2 1 1 -o 0.5 0 0 -clamp on .\\t x.png\n"
                "newmtl plain\nKd 0.5 0.5 0.5\n");
        if (uri == "m/t x.png")
            return png;
        return Status::error(Code::not_found, uri);
    };
    auto m = load(
        "mtllib m/a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
        "usemtl tex\nf 1/1 2/2 3/3\nusemtl plain\nf 1/1 2/2 3/3\n",
        ModelFormat::obj, reader);
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_TRUE(m->warnings.empty()) << m->warnings[0];
    EXPECT_EQ(asked, (std::vector<std::string>{"m/a.mtl", "m/t x.png"}));
    ASSERT_EQ(m->materials.size(), 2u);
    ASSERT_TRUE(m->materials[0].texture);
    EXPECT_FALSE(m->materials[1].texture);
    EXPECT_EQ(m->materials[0].texture->wrap_s, TextureWrap::clamp_to_edge);
    EXPECT_EQ(m->materials[0].texture->image->rgb,
              (std::vector<std::uint8_t>{255, 0, 0, 0, 0, 255}));
    using Corner = std::array<float, 2>;
    const auto& uv = m->parts[0].mesh.corner_uvs;
    ASSERT_EQ(uv.size(), 2u);
    EXPECT_EQ(uv[0][0], (Corner{0.5f, 1.0f}));  // (2·0 + 0.5, 1 − 0)
    EXPECT_EQ(uv[0][1], (Corner{2.5f, 1.0f}));
    EXPECT_EQ(uv[0][2], (Corner{0.5f, 0.0f}));
    EXPECT_EQ(uv[1][1], (Corner{1.0f, 1.0f}));  // the untextured material: no -s, -o
}

// A texture index out of range costs the texture coordinates, not the face; a map that cannot
// be read costs the texture, not the material.
TEST(ObjReader, BadTextureIndexAndMissingMapAreWarnings) {
    ResourceReader reader = [&](const std::string& uri) -> Result<std::string> {
        if (uri == "a.mtl")
            return std::string("newmtl tex\nmap_Kd gone.png\n");
        return Status::error(Code::not_found, uri + " not found");
    };
    auto m = load("mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl tex\nf 1/1 2/7 3/1\n",
                  ModelFormat::obj, reader);
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_EQ(m->parts[0].mesh.size(), 1u);
    EXPECT_TRUE(m->parts[0].mesh.corner_uvs.empty());
    EXPECT_FALSE(m->materials[0].texture);
    ASSERT_EQ(m->warnings.size(), 2u);
    EXPECT_NE(m->warnings[0].find("gone.png"), std::string::npos) << m->warnings[0];
    EXPECT_NE(m->warnings[1].find("texture index"), std::string::npos) << m->warnings[1];
}

// What map_Kd names, word by word: an unknown option is part of the file name (it had been
// dropped, and "-zz a.png" asked for a.png); a '#' is part of it too (no comment there); a
// number that is not finite or out of range ends -s's numbers; "+-1" is one (the '+' dropped).
TEST(ObjReader, DiffuseMapNamesAreReadWordByWord) {
    for (const auto& [map, name] : {std::pair{"-zz a.png", "-zz a.png"},
                                    {"tex#1.png", "tex#1.png"},
                                    {"-s 1 inf a.png", "inf a.png"},
                                    {"-s 1 1e-400 a.png", "1e-400 a.png"},
                                    {"-s +-1 1 1 a.png", "a.png"},
                                    {"-clamp on -bm 2 a b.png", "a b.png"}}) {
        std::vector<std::string> asked;
        // A copy: C++17 lambdas cannot capture a structured binding (clang refuses it).
        const std::string line = "newmtl t\nmap_Kd " + std::string(map) + "\n";
        ResourceReader reader = [&](const std::string& uri) -> Result<std::string> {
            asked.push_back(uri);
            if (uri == "a.mtl")
                return line;
            return Status::error(Code::not_found, uri);
        };
        auto m = load("mtllib a.mtl\nusemtl t\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
                      ModelFormat::obj, reader);
        ASSERT_TRUE(m.ok()) << m.status().message;
        EXPECT_EQ(asked, (std::vector<std::string>{"a.mtl", name})) << map;
    }
}

TEST(ObjReader, RefusesAbsoluteAndSchemeMtllib) {
    bool asked = false;
    ResourceReader reader = [&](const std::string&) -> Result<std::string> {
        asked = true;
        return std::string();
    };
    for (const char* lib :
         {"mtllib /etc/passwd\n", "mtllib http://x/y.mtl\n", "mtllib C:\\x.mtl\n"}) {
        auto m = load(std::string(lib) + "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", ModelFormat::obj,
                      reader);
        ASSERT_TRUE(m.ok());
        EXPECT_FALSE(asked) << lib;
    }
}

TEST(ObjReader, LinesPointsShortFacesAndContinuations) {
    auto m = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\np 1\nf 1 2\nf 1 \\\n 2 3\n", ModelFormat::obj);
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_EQ(m->triangle_count(), 1u);
    EXPECT_EQ(m->warnings.size(), 2u);
}

TEST(PlyReader, AsciiWithQuadsNormalsAndExtraProperties) {
    auto m = load(
        "ply\nformat ascii 1.0\ncomment hi\nelement vertex 4\nproperty float x\nproperty float y\n"
        "property double z\nproperty float nx\nproperty float ny\nproperty float nz\n"
        "property uchar red\nelement face 2\nproperty list uchar int vertex_indices\n"
        "property float quality\nend_header\n"
        "0 0 0 0 0 1 255\n1 0 0 0 0 1 0\n1 1 0 0 0 1 0\n0 1 0 0 0 1 0\n4 0 1 2 3 0.5\n3 3 2 1 1\n",
        ModelFormat::ply);
    ASSERT_TRUE(m.ok()) << m.status().message;
    const TriangleMesh& mesh = m->parts[0].mesh;
    EXPECT_EQ(mesh.triangles, (std::vector<Tri>{{0, 1, 2}, {0, 2, 3}, {3, 2, 1}}));
    EXPECT_EQ(mesh.positions[2], Vec3d(1, 1, 0));
    ASSERT_EQ(mesh.normals.size(), 4u);
}

template <class T>
void put_be(std::string& out, T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (std::size_t i = sizeof(T); i-- > 0;)
        out += b[i];
}

TEST(PlyReader, BinaryLittleAndBigEndianAgree) {
    const std::string header_tail =
        " 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar uint vertex_indices\nend_header\n";
    const std::vector<float> xyz = {0, 0, 0, 2, 0, 0, 0, 3, 0};
    std::string le = "ply\nformat binary_little_endian" + header_tail;
    le.append(reinterpret_cast<const char*>(xyz.data()), 36);
    le += '\3';
    for (std::uint32_t i : {0u, 1u, 2u})
        le.append(reinterpret_cast<const char*>(&i), 4);
    std::string be = "ply\nformat binary_big_endian" + header_tail;
    for (float f : xyz)
        put_be(be, f);
    be += '\3';
    for (std::uint32_t i : {0u, 1u, 2u})
        put_be(be, i);
    auto a = load(le, ModelFormat::ply);
    auto b = load(be, ModelFormat::ply);
    ASSERT_TRUE(a.ok()) << a.status().message;
    ASSERT_TRUE(b.ok()) << b.status().message;
    EXPECT_EQ(a->parts[0].mesh.positions, b->parts[0].mesh.positions);
    EXPECT_EQ(a->parts[0].mesh.positions[2], Vec3d(0, 3, 0));
    EXPECT_EQ(a->parts[0].mesh.triangles, (std::vector<Tri>{{0, 1, 2}}));
    // Truncating the binary data anywhere is an error, never a read past the end.
    for (std::size_t n = le.find("end_header") + 11; n < le.size(); ++n) {
        EXPECT_FALSE(load(le.substr(0, n), ModelFormat::ply).ok()) << n;
    }
}

// Counts that the data cannot hold are refused at once (a 4-billion-entry face list in a
// short file must not allocate or loop).
TEST(PlyReader, LyingCountsAreRefusedCheaply) {
    const std::string head =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n0 1 0\n";
    EXPECT_FALSE(load(head + "4000000000 0 1 2\n", ModelFormat::ply).ok());
    EXPECT_FALSE(
        load("ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nend_header\n1\n",
             ModelFormat::ply)
            .ok());
    EXPECT_FALSE(load(head + "3 0 1 7\n", ModelFormat::ply).ok());  // index past the vertices
    EXPECT_FALSE(
        load("ply\nformat ascii 1.0\nproperty float x\nend_header\n", ModelFormat::ply).ok());
    EXPECT_FALSE(
        load("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", ModelFormat::ply).ok());
}

TEST(StlReader, AsciiAndBinaryWeldIdenticalCorners) {
    auto a = load(
        "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 "
        "0\nendloop\nendfacet\n"
        "facet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 "
        "0\nendloop\nendfacet\nendsolid t\n",
        ModelFormat::stl);
    ASSERT_TRUE(a.ok()) << a.status().message;
    EXPECT_EQ(a->parts[0].mesh.positions.size(), 4u);
    EXPECT_EQ(a->parts[0].mesh.triangles, (std::vector<Tri>{{0, 1, 2}, {1, 3, 2}}));
    auto b = load(binary_stl("solid x", {{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 0, 0, 1, 1, 0, 0, 1, 0}}),
                  ModelFormat::stl);
    ASSERT_TRUE(b.ok()) << b.status().message;
    EXPECT_EQ(b->parts[0].mesh.positions, a->parts[0].mesh.positions);
    EXPECT_EQ(b->parts[0].mesh.triangles, a->parts[0].mesh.triangles);
}

// A triangle whose corners coincide is kept (zero area, never hit), so later triangles keep
// their file numbers.
TEST(StlReader, DegenerateTrianglesKeepNumbering) {
    auto m = load(binary_stl("", {{0, 0, 0, 0, 0, 0, 1, 0, 0}, {0, 0, 0, 1, 0, 0, 0, 1, 0}}),
                  ModelFormat::stl);
    ASSERT_TRUE(m.ok());
    EXPECT_EQ(m->triangle_count(), 2u);
}

TEST(StlReader, TruncatedBinaryAndBrokenAscii) {
    std::string b = binary_stl("x", {{0, 0, 0, 1, 0, 0, 0, 1, 0}});
    EXPECT_FALSE(load(b.substr(0, b.size() - 1), ModelFormat::stl).ok());
    EXPECT_FALSE(load(b.substr(0, 50), ModelFormat::stl).ok());
    EXPECT_FALSE(load("solid t\nfacet\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\n",
                      ModelFormat::stl)
                     .ok());
    EXPECT_FALSE(load("solid t\nfacet\nouter loop\nvertex 0 0\n", ModelFormat::stl).ok());
}

TEST(OffReader, CommentsGluedHeaderAndColours) {
    auto m = load(
        "# cube\nOFF4 2 0 # counts glued to the keyword\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n"
        "4 0 1 2 3 255 0 0\n3 0 2 3\n",
        ModelFormat::off);
    ASSERT_TRUE(m.ok()) << m.status().message;
    EXPECT_EQ(m->parts[0].mesh.triangles, (std::vector<Tri>{{0, 1, 2}, {0, 2, 3}, {0, 2, 3}}));
    auto n =
        load("NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n", ModelFormat::off);
    ASSERT_TRUE(n.ok()) << n.status().message;
    EXPECT_EQ(n->parts[0].mesh.normals.size(), 3u);
}

TEST(OffReader, BrokenFilesAreErrors) {
    EXPECT_FALSE(load("OFF\n3 1 0\n0 0 0\n1 0 0\n", ModelFormat::off).ok());
    EXPECT_FALSE(load("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", ModelFormat::off).ok());
    EXPECT_FALSE(load("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n5 0 1 2\n", ModelFormat::off).ok());
    EXPECT_FALSE(load("OFF\n99999999 1 0\n", ModelFormat::off).ok());
    EXPECT_EQ(load("OFF BINARY\n", ModelFormat::off).status().code, Code::unsupported_format);
    EXPECT_EQ(load("4OFF\n1 0 0\n", ModelFormat::off).status().code, Code::unsupported_format);
}

TEST(ApplyTransform, MovesEverythingAndFlipsMirroredWinding) {
    auto m = load("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n", ModelFormat::obj);
    ASSERT_TRUE(m.ok());
    m->lights.push_back({LightType::point, {1, 0, 0}, {}, {1, 1, 1}});
    m->camera = Camera{{0, 0, -5}, {0, 0, 0}, {0, 1, 0}, 45};
    apply_transform(*m, Transform::translate({0, 0, 10}) * Transform::scale({-2, 2, 2}));
    const TriangleMesh& mesh = m->parts[0].mesh;
    EXPECT_EQ(mesh.positions[1], Vec3d(-2, 0, 10));
    EXPECT_EQ(mesh.triangles[0], (Tri{0, 2, 1}));
    const Triangle t = mesh.triangle(0);
    EXPECT_GT(cross(t.b - t.a, t.c - t.a).z, 0.0);  // still facing +z, like its normal
    EXPECT_EQ(mesh.normals[0], Vec3f(0, 0, 1));
    EXPECT_EQ(m->lights[0].position, Vec3d(-2, 0, 10));
    EXPECT_EQ(m->camera->position, Vec3d(0, 0, 0));
}

// Deterministic mutations (byte flips, truncations, splices) of a valid file of every format:
// each load returns a value or a Status, and a returned model is internally consistent. The
// sanitizer build turns any out-of-bounds read into a failure here.
TEST(LoaderRobustness, MutatedInputsNeverCrash) {
    const std::string obj =
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nusemtl a\nf 1//1 2//1 3//1\nf -1 -2 "
        "-3\n";
    const std::string ply =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    const std::string off = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    const std::string stl =
        binary_stl("x", {{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 0, 0, 1, 1, 0, 0, 1, 0}});
    const std::string gltf =
        R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,)"
        R"(AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],"bufferViews":[{"buffer":0,"byteLength":36}],)"
        R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}],)"
        R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]})";
    ASSERT_TRUE(load(gltf, ModelFormat::gltf).ok());
    const std::vector<std::pair<std::string, ModelFormat>> seeds = {{obj, ModelFormat::obj},
                                                                    {ply, ModelFormat::ply},
                                                                    {off, ModelFormat::off},
                                                                    {stl, ModelFormat::stl},
                                                                    {gltf, ModelFormat::gltf}};
    std::mt19937 rng(12345);
    ResourceReader mtl = [](const std::string&) -> Result<std::string> {
        return std::string("newmtl a\nKd 1 1\n");
    };
    for (const auto& [seed, format] : seeds) {
        for (int i = 0; i < 300; ++i) {
            std::string s = seed;
            switch (rng() % 3) {
                case 0:
                    for (int k = 0; k < 3; ++k)
                        s[rng() % s.size()] = static_cast<char>(rng());
                    break;
                case 1:
                    s.resize(rng() % s.size());
                    break;
                default:
                    s.insert(rng() % s.size(), s.substr(rng() % s.size(), 8));
            }
            auto m = load_model(s, format, mtl, "fuzz");
            if (!m.ok())
                continue;
            for (const ModelPart& part : m->parts) {
                for (const auto& t : part.mesh.triangles) {
                    for (std::uint32_t v : t)
                        ASSERT_LT(v, part.mesh.positions.size());
                }
            }
        }
    }
}

}  // namespace
}  // namespace raycastd::engine
