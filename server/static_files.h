#pragma once
// StaticFiles: the preview page's files (clients/web/) read from a directory at request time, so
// that editing the page needs no rebuild. A request path is confined to the directory: it is
// checked segment by segment (no "..", ".", empty or hidden segments, no backslash, NUL or
// control characters), then resolved with realpath so that a symlink pointing out of the
// directory is refused too. Only regular files with a known extension are served, each with its
// MIME type and a validator (ETag) for cheap revalidation.

#include <cstdint>
#include <optional>
#include <string>

namespace raycastd::server {

/// The MIME type served for a file name's extension ("app.js" → "text/javascript;
/// charset=utf-8"), or nullopt for an extension the page does not use (not served).
std::optional<std::string> mime_type_of(const std::string& name);

/// Why a path was not served.
enum class StaticError {
    refused,    ///< the path tries to leave the directory or is malformed (400)
    not_found,  ///< no such regular file, or an extension that is not served (404)
};

struct StaticFile {
    std::string body;
    std::string mime_type;
    std::string etag;  ///< "\"<size>-<mtime ns, hex>\"": changes whenever the file is rewritten
};

struct StaticResult {
    std::optional<StaticFile> file;
    StaticError error = StaticError::not_found;
    std::string message;  ///< set when `file` is empty
};

class StaticFiles {
  public:
    /// Serves the files under `root` (need not exist: every lookup is then not_found).
    explicit StaticFiles(std::string root);

    /// The file at `relative` ("index.html", "js/app.js"; percent-decoded, no leading '/').
    /// Files over `max_bytes` are not_found (the page has no large files).
    StaticResult read(const std::string& relative, std::size_t max_bytes = 16u << 20) const;

    const std::string& root() const { return root_; }
    /// False when the root directory does not exist (the page is not installed).
    bool available() const { return !real_root_.empty(); }

  private:
    std::string root_;
    std::string real_root_;  ///< realpath of root_, "" when it does not exist
};

/// Checks a relative request path segment by segment; the message says why it is refused, or
/// is empty when the path is acceptable.
std::string refusal_reason(const std::string& relative);

}  // namespace raycastd::server
