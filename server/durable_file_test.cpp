// Durable files: bytes written and synced, atomic replacement by rename, and errors (never a
// crash or a silent success) for a missing or read-only directory.

#include "server/durable_file.h"

#include <cerrno>
#include <filesystem>

#include <gtest/gtest.h>
#include <unistd.h>

namespace raycastd::server {
namespace {

namespace fs = std::filesystem;

struct TempDir {
    fs::path path = fs::temp_directory_path() /
                    ("raycastd_durable_" + std::to_string(::getpid()) + "_" +
                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    TempDir() {
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~TempDir() {
        std::error_code ec;
        fs::permissions(path, fs::perms::owner_all, fs::perm_options::add, ec);
        fs::remove_all(path, ec);
    }
};

TEST(DurableFile, WritesAndTruncates) {
    TempDir dir;
    IoError error;
    const fs::path f = dir.path / "body";
    ASSERT_TRUE(write_synced(f, std::string("a\0b", 3), error)) << error.message;
    EXPECT_EQ(read_file(f), std::string("a\0b", 3));
    ASSERT_TRUE(write_synced(f, "c", error)) << error.message;
    EXPECT_EQ(read_file(f), "c");
    ASSERT_TRUE(write_synced(dir.path / "empty", "", error)) << error.message;
    EXPECT_EQ(read_file(dir.path / "empty"), "");
    EXPECT_TRUE(sync_dir(dir.path, error)) << error.message;
    EXPECT_FALSE(read_file(dir.path / "absent"));
}

TEST(DurableFile, RenameReplacesAFileAtomically) {
    TempDir dir;
    IoError error;
    const fs::path target = dir.path / "meta.json";
    ASSERT_TRUE(write_synced(target, "old", error)) << error.message;
    const fs::path staged = dir.path / "meta.json.tmp";
    ASSERT_TRUE(write_synced(staged, "new", error)) << error.message;
    // Until the rename the old bytes are in place; after it, the new ones, and no temp name.
    EXPECT_EQ(read_file(target), "old");
    ASSERT_TRUE(rename_synced(staged, target, error)) << error.message;
    EXPECT_EQ(read_file(target), "new");
    EXPECT_FALSE(fs::exists(staged));
}

TEST(DurableFile, RenamePublishesADirectoryWhole) {
    TempDir dir;
    IoError error;
    fs::create_directories(dir.path / "tmp" / "sc_1");
    fs::create_directories(dir.path / "scenes");
    ASSERT_TRUE(write_synced(dir.path / "tmp" / "sc_1" / "body", "{}", error)) << error.message;
    ASSERT_TRUE(rename_synced(dir.path / "tmp" / "sc_1", dir.path / "scenes" / "sc_1", error))
        << error.message;
    EXPECT_EQ(read_file(dir.path / "scenes" / "sc_1" / "body"), "{}");
    EXPECT_FALSE(fs::exists(dir.path / "tmp" / "sc_1"));
}

TEST(DurableFile, MissingDirectoryIsAnError) {
    TempDir dir;
    const fs::path missing = dir.path / "no" / "such";
    IoError error;
    EXPECT_FALSE(write_synced(missing / "body", "x", error));
    EXPECT_NE(error.message.find((missing / "body").string()), std::string::npos) << error.message;
    EXPECT_FALSE(error.storage_refused());  // a missing directory is our bug, not the disk's
    error = {};
    EXPECT_FALSE(sync_dir(missing, error));
    EXPECT_FALSE(error.message.empty());
    error = {};
    ASSERT_TRUE(write_synced(dir.path / "a", "x", error)) << error.message;
    EXPECT_FALSE(rename_synced(dir.path / "a", missing / "a", error));
    EXPECT_FALSE(error.message.empty());
    EXPECT_EQ(read_file(dir.path / "a"), "x");  // a failed rename moves nothing
}

TEST(DurableFile, ReadOnlyDirectoryIsAnError) {
    TempDir dir;
    IoError error;
    ASSERT_TRUE(write_synced(dir.path / "kept", "old", error)) << error.message;
    fs::permissions(dir.path, fs::perms::owner_read | fs::perms::owner_exec);
    // Root ignores permission bits: then /proc, where no file can be created, stands in.
    const fs::path read_only = ::geteuid() == 0 ? fs::path("/proc") : dir.path;
    EXPECT_FALSE(write_synced(read_only / "raycastd_new", "x", error));
    EXPECT_FALSE(error.message.empty());
    error = {};
    EXPECT_FALSE(rename_synced(dir.path / "kept", read_only / "raycastd_moved", error));
    EXPECT_FALSE(error.message.empty());
    EXPECT_EQ(read_file(dir.path / "kept"), "old");
}

TEST(DurableFile, StorageRefusalsAreTheDisksNotOurs) {
    for (int code : {ENOSPC, EDQUOT, EROFS, EACCES, EPERM, EFBIG})
        EXPECT_TRUE((IoError{"", code}).storage_refused()) << code;
    for (int code : {0, ENOENT, EISDIR, EBADF, EIO})
        EXPECT_FALSE((IoError{"", code}).storage_refused()) << code;
}

TEST(DurableFile, AFullDiskIsAStorageRefusal) {
    // /dev/full answers every write with ENOSPC.
    IoError error;
    EXPECT_FALSE(write_synced("/dev/full", "x", error));
    EXPECT_EQ(error.code, ENOSPC) << error.message;
    EXPECT_TRUE(error.storage_refused());
}

}  // namespace
}  // namespace raycastd::server
