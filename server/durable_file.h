#pragma once
// Durable writes for the data directory: bytes are on disk, and names point at them, before a
// scene is acknowledged. A file is written and fsynced; a name is made durable by fsyncing the
// directory that holds it (POSIX keeps data and directory entries apart: without the second
// fsync a crash can lose a renamed file whose bytes are safe). Whole-or-nothing publication is
// a rename(2), which replaces its target atomically.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace raycastd::server {

/// Why a durable write failed: the message names the path, `code` is the errno.
struct IoError {
    std::string message;
    int code = 0;
    /// The storage refused the write (full, over quota, read-only, not permitted, file too
    /// large): the API's 507, as opposed to a bug.
    bool storage_refused() const;
};

/// Creates or truncates `path`, writes all of `bytes` and fsyncs it. False, with `error`
/// naming the path and the reason, when any step fails (a missing or read-only directory).
bool write_synced(const std::filesystem::path& path, std::string_view bytes, IoError& error);

/// Fsyncs a directory, so that the names created, renamed or removed in it survive a crash.
/// False, with `error`, when it cannot be opened or synced.
bool sync_dir(const std::filesystem::path& dir, IoError& error);

/// Renames `from` to `to` and fsyncs the directories of both: a file `to` is replaced
/// atomically (readers see the old bytes or the new, never a mix); a directory `to` must be
/// absent or empty. False, with `error`, when the rename or a sync fails (nothing is renamed
/// when the rename fails).
bool rename_synced(const std::filesystem::path& from, const std::filesystem::path& to,
                   IoError& error);

/// The whole file, or nullopt when it cannot be read.
std::optional<std::string> read_file(const std::filesystem::path& path);

}  // namespace raycastd::server
