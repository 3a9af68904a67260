#include "server/static_files.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <unistd.h>

namespace raycastd::server {
namespace {

namespace fs = std::filesystem;

TEST(StaticFiles, MimeTypesByExtension) {
    EXPECT_EQ(mime_type_of("index.html"), "text/html; charset=utf-8");
    EXPECT_EQ(mime_type_of("js/app.js"), "text/javascript; charset=utf-8");
    EXPECT_EQ(mime_type_of("STYLE.CSS"), "text/css; charset=utf-8");
    EXPECT_EQ(mime_type_of("icon.svg"), "image/svg+xml");
    EXPECT_FALSE(mime_type_of("server.cpp"));
    EXPECT_FALSE(mime_type_of("Makefile"));
    EXPECT_FALSE(mime_type_of("a.js/readme"));
}

TEST(StaticFiles, RefusesEscapesAndMalformedPaths) {
    for (const char* ok : {"index.html", "js/app.js", "a/b/c.css"})
        EXPECT_EQ(refusal_reason(ok), "") << ok;
    for (const char* bad :
         {"", "/etc/passwd", "../secret.txt", "js/../../x.js", "a/./b.js", "js//app.js", "js/",
          ".git/config", "a\\b.js", "C:x.js", "..", "a/.."}) {
        EXPECT_NE(refusal_reason(bad), "") << bad;
    }
    EXPECT_NE(refusal_reason(std::string("a\0b.js", 6)), "");
}

class StaticFilesDir : public ::testing::Test {
  protected:
    void SetUp() override {
        base_ = fs::temp_directory_path() / ("raycastd_web_" + std::to_string(::getpid()));
        fs::remove_all(base_);
        fs::create_directories(base_ / "root" / "js");
        std::ofstream(base_ / "root" / "index.html") << "<!doctype html><title>t</title>";
        std::ofstream(base_ / "root" / "js" / "app.js") << "export {};\n";
        std::ofstream(base_ / "root" / "notes.cpp") << "int x;\n";
        std::ofstream(base_ / "secret.txt") << "secret\n";
        fs::create_symlink(base_ / "secret.txt", base_ / "root" / "link.txt");
        fs::create_directories(base_ / "root" / "dir.js");
    }
    void TearDown() override { fs::remove_all(base_); }
    fs::path base_;
};

TEST_F(StaticFilesDir, ServesFilesWithTypeAndValidator) {
    StaticFiles files((base_ / "root").string());
    ASSERT_TRUE(files.available());
    StaticResult r = files.read("js/app.js");
    ASSERT_TRUE(r.file) << r.message;
    EXPECT_EQ(r.file->body, "export {};\n");
    EXPECT_EQ(r.file->mime_type, "text/javascript; charset=utf-8");
    EXPECT_EQ(r.file->etag.front(), '"');
    EXPECT_EQ(r.file->etag, files.read("js/app.js").file->etag);
}

TEST_F(StaticFilesDir, MissingUnservedAndEscapingFilesAreNotServed) {
    StaticFiles files((base_ / "root").string());
    auto expect = [&](const char* path, StaticError error) {
        StaticResult r = files.read(path);
        EXPECT_FALSE(r.file) << path;
        EXPECT_EQ(r.error, error) << path;
        EXPECT_FALSE(r.message.empty()) << path;
    };
    expect("missing.js", StaticError::not_found);
    expect("notes.cpp", StaticError::not_found);  // not a type the page uses
    expect("dir.js", StaticError::not_found);     // a directory
    expect("../secret.txt", StaticError::refused);
    expect("link.txt", StaticError::refused);  // a symlink out of the root
}

TEST(StaticFiles, AMissingRootServesNothing) {
    StaticFiles files("/nonexistent/raycastd/web");
    EXPECT_FALSE(files.available());
    StaticResult r = files.read("index.html");
    EXPECT_FALSE(r.file);
    EXPECT_EQ(r.error, StaticError::not_found);
    EXPECT_NE(r.message.find("RAYCASTD_WEB_ROOT"), std::string::npos);
}

}  // namespace
}  // namespace raycastd::server
