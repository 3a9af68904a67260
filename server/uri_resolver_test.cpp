#include "server/uri_resolver.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <unistd.h>

namespace raycastd::server {
namespace {

namespace fs = std::filesystem;

TEST(UriResolver, NormalizesAndRefusesEscapes) {
    EXPECT_EQ(*normalize_relative("a/./b/../c.obj"), "a/c.obj");
    EXPECT_EQ(*normalize_relative("models//Duck.glb"), "models/Duck.glb");
    for (const char* bad : {"../x.obj", "a/../../x.obj", "/etc/passwd", "http://example.com/x.glb",
                            "file:///etc/passwd", "C:/x.obj", "", ".", "a/.."}) {
        auto r = normalize_relative(bad);
        EXPECT_FALSE(r.ok()) << bad;
        if (!r.ok()) {
            EXPECT_EQ(r.status().code, engine::Code::invalid_scene) << bad;
        }
    }
    EXPECT_FALSE(normalize_relative(std::string("a\0b", 3)).ok());
    EXPECT_EQ(*join_relative("Duck/glTF", "Duck0.bin"), "Duck/glTF/Duck0.bin");
    EXPECT_EQ(*join_relative("a/b", "../c.bin"), "a/c.bin");
    EXPECT_FALSE(join_relative("a", "../../c.bin").ok());
    EXPECT_EQ(dirname_of("a/b/c.gltf"), "a/b");
    EXPECT_EQ(dirname_of("c.gltf"), "");
}

TEST(UriResolver, SymlinksOutOfTheRootAreRefused) {
    const fs::path base =
        fs::temp_directory_path() / ("raycastd_root_" + std::to_string(::getpid()));
    fs::remove_all(base);
    fs::create_directories(base / "root" / "sub");
    std::ofstream(base / "root" / "sub" / "in.obj") << "v 0 0 0\n";
    std::ofstream(base / "secret.obj") << "v 1 1 1\n";
    fs::create_symlink(base / "secret.obj", base / "root" / "link.obj");
    fs::create_symlink(base / "root" / "sub" / "in.obj", base / "root" / "inside_link.obj");

    SceneRoot root((base / "root").string());
    EXPECT_EQ(*root.read("sub/in.obj", 1000), "v 0 0 0\n");
    EXPECT_EQ(*root.read("inside_link.obj", 1000), "v 0 0 0\n");
    auto out = root.read("link.obj", 1000);
    ASSERT_FALSE(out.ok());
    EXPECT_NE(out.status().message.find("outside the scene root"), std::string::npos);
    EXPECT_FALSE(root.read("missing.obj", 1000).ok());
    EXPECT_FALSE(root.read("sub", 1000).ok());  // a directory
    EXPECT_EQ(root.read("sub/in.obj", 3).status().code, engine::Code::too_large);
    fs::remove_all(base);
}

}  // namespace
}  // namespace raycastd::server
