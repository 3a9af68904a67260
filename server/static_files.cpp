#include "server/static_files.h"

#include <array>
#include <cctype>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <utility>

#include <sys/stat.h>

namespace raycastd::server {

namespace {

std::string real_path(const std::string& p) {
    char buf[PATH_MAX];
    return ::realpath(p.c_str(), buf) ? std::string(buf) : std::string();
}

std::string lower(std::string s) {
    for (char& c : s)
        c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

StaticResult fail(StaticError error, std::string message) {
    StaticResult r;
    r.error = error;
    r.message = std::move(message);
    return r;
}

}  // namespace

std::optional<std::string> mime_type_of(const std::string& name) {
    // Module scripts must come with a JavaScript MIME type (HTML §8.1.5.2: "strict MIME type
    // checking"), and nosniff (set by the route) makes the browser trust only this table.
    static const std::array<std::pair<const char*, const char*>, 13> kTypes = {{
        {".html", "text/html; charset=utf-8"},
        {".js", "text/javascript; charset=utf-8"},
        {".mjs", "text/javascript; charset=utf-8"},
        {".css", "text/css; charset=utf-8"},
        {".json", "application/json"},
        {".svg", "image/svg+xml"},
        {".png", "image/png"},
        {".ico", "image/x-icon"},
        {".txt", "text/plain; charset=utf-8"},
        {".md", "text/markdown; charset=utf-8"},
        {".woff2", "font/woff2"},
        {".webp", "image/webp"},
        {".map", "application/json"},
    }};
    const auto dot = name.rfind('.');
    if (dot == std::string::npos || name.find('/', dot) != std::string::npos)
        return std::nullopt;
    const std::string ext = lower(name.substr(dot));
    for (const auto& [e, type] : kTypes) {
        if (ext == e)
            return std::string(type);
    }
    return std::nullopt;
}

std::string refusal_reason(const std::string& relative) {
    if (relative.empty())
        return "empty path";
    if (relative[0] == '/')
        return "absolute paths are refused";
    std::size_t start = 0;
    while (start <= relative.size()) {
        const std::size_t end = std::min(relative.find('/', start), relative.size());
        const std::string seg = relative.substr(start, end - start);
        if (seg.empty())
            return "empty path segment";
        if (seg == "." || seg == "..")
            return "\"" + seg + "\" segments are refused: the path must stay inside the web root";
        if (seg[0] == '.')
            return "hidden files are not served";
        for (char c : seg) {
            const auto u = static_cast<unsigned char>(c);
            if (u < 0x20 || u == 0x7f || c == '\\' || c == ':')
                return "the path holds a control character, a backslash or a colon";
        }
        start = end + 1;
    }
    return {};
}

StaticFiles::StaticFiles(std::string root) : root_(std::move(root)), real_root_(real_path(root_)) {
    struct stat st {};
    if (!real_root_.empty() && (::stat(real_root_.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)))
        real_root_.clear();
}

StaticResult StaticFiles::read(const std::string& relative, std::size_t max_bytes) const {
    if (std::string why = refusal_reason(relative); !why.empty())
        return fail(StaticError::refused, why);
    if (!available()) {
        return fail(StaticError::not_found, "the preview page is not installed: " + root_ +
                                                " is not a directory (set RAYCASTD_WEB_ROOT)");
    }
    auto mime = mime_type_of(relative);
    if (!mime)
        return fail(StaticError::not_found, "no such file: " + relative);
    // The lexical check above rules out "..", so only a symlink can lead out of the root.
    const std::string real = real_path(real_root_ + "/" + relative);
    if (real.empty())
        return fail(StaticError::not_found, "no such file: " + relative);
    if (real.compare(0, real_root_.size() + 1, real_root_ + "/") != 0)
        return fail(StaticError::refused, relative + " leads out of the web root");
    struct stat st {};
    if (::stat(real.c_str(), &st) != 0 || !S_ISREG(st.st_mode))
        return fail(StaticError::not_found, "no such file: " + relative);
    if (static_cast<std::size_t>(st.st_size) > max_bytes)
        return fail(StaticError::not_found, relative + " is over the static file size limit");
    std::ifstream f(real, std::ios::binary);
    std::ostringstream ss;
    if (!(ss << f.rdbuf()) && st.st_size > 0)
        return fail(StaticError::not_found, "cannot read " + relative);
    StaticFile out;
    out.body = ss.str();
    out.mime_type = *mime;
    const auto mtime_ns = static_cast<unsigned long long>(st.st_mtim.tv_sec) * 1000000000ull +
                          static_cast<unsigned long long>(st.st_mtim.tv_nsec);
    char etag[64];
    std::snprintf(etag, sizeof etag, "\"%zx-%llx\"", out.body.size(), mtime_ns);
    out.etag = etag;
    StaticResult r;
    r.file = std::move(out);
    return r;
}

}  // namespace raycastd::server
