#pragma once
// Scene-root confinement for the files a scene refers to (docs/api.md: `uri` resolves inside the
// server's scene root only; absolute paths, `..` escapes and symlinks out of the root are
// refused). Paths are normalised lexically first ("a/./b/../c" → "a/c"), then resolved with
// realpath so that a symlink pointing outside the root is caught too.

#include <string>

#include "engine/status.h"

namespace raycastd::server {

/// "a/./b/../c" → "a/c". Fails (invalid_scene) for empty, absolute, scheme-carrying
/// ("http://…", "file:…") or NUL-carrying paths and for `..` that climbs above the start.
engine::Result<std::string> normalize_relative(const std::string& path);

/// The directory part of a normalised relative path ("a/b/c.gltf" → "a/b", "c.gltf" → "").
std::string dirname_of(const std::string& path);

/// Joins a directory and a relative reference, then normalises ("a/b" + "../c" → "a/c").
engine::Result<std::string> join_relative(const std::string& dir, const std::string& ref);

class SceneRoot {
  public:
    explicit SceneRoot(std::string root);

    /// The bytes of the normalised relative path inside the root: invalid_scene when it escapes
    /// (through a symlink too) or does not name a regular file; too_large above max_bytes.
    engine::Result<std::string> read(const std::string& normalized, std::size_t max_bytes) const;

    const std::string& root() const { return root_; }

  private:
    std::string root_;
};

}  // namespace raycastd::server
