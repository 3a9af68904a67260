#include "server/uri_resolver.h"

#include <cctype>
#include <climits>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include <sys/stat.h>

namespace raycastd::server {

namespace {

using engine::Code;
using engine::Status;

bool has_scheme(const std::string& p) {
    // RFC 3986 §3.1: scheme = ALPHA *( ALPHA / DIGIT / "+" / "-" / "." ) ":"
    if (p.empty() || !std::isalpha(static_cast<unsigned char>(p[0])))
        return false;
    for (char c : p) {
        if (c == ':')
            return true;
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '+' && c != '-' && c != '.') {
            return false;
        }
    }
    return false;
}

std::string real_path(const std::string& p) {
    char buf[PATH_MAX];
    return ::realpath(p.c_str(), buf) ? std::string(buf) : std::string();
}

}  // namespace

engine::Result<std::string> normalize_relative(const std::string& path) {
    if (path.empty())
        return Status::error(Code::invalid_scene, "empty path");
    if (path.find('\0') != std::string::npos) {
        return Status::error(Code::invalid_scene, "path contains a NUL byte");
    }
    if (path[0] == '/' || path[0] == '\\') {
        return Status::error(Code::invalid_scene, "absolute paths are refused: \"" + path +
                                                      "\" (use a path relative "
                                                      "to the scene root)");
    }
    if (has_scheme(path)) {
        return Status::error(
            Code::invalid_scene,
            "only files inside the scene root can be referenced, not \"" + path + "\"");
    }
    std::vector<std::string> parts;
    std::stringstream ss(path);
    std::string part;
    while (std::getline(ss, part, '/')) {
        if (part.empty() || part == ".")
            continue;
        if (part == "..") {
            if (parts.empty()) {
                return Status::error(Code::invalid_scene,
                                     "\"" + path + "\" escapes the scene root");
            }
            parts.pop_back();
            continue;
        }
        parts.push_back(part);
    }
    if (parts.empty())
        return Status::error(Code::invalid_scene, "\"" + path + "\" names no file");
    std::string out;
    for (const auto& p : parts)
        out += (out.empty() ? "" : "/") + p;
    return out;
}

std::string dirname_of(const std::string& path) {
    const auto slash = path.rfind('/');
    return slash == std::string::npos ? std::string() : path.substr(0, slash);
}

engine::Result<std::string> join_relative(const std::string& dir, const std::string& ref) {
    if (!ref.empty() && (ref[0] == '/' || has_scheme(ref)))
        return normalize_relative(ref);
    return normalize_relative(dir.empty() ? ref : dir + "/" + ref);
}

SceneRoot::SceneRoot(std::string root) : root_(std::move(root)) {}

engine::Result<std::string> SceneRoot::read(const std::string& normalized,
                                            std::size_t max_bytes) const {
    const std::string root_real = real_path(root_);
    if (root_real.empty()) {
        return Status::error(Code::invalid_scene, "the server's scene root does not exist");
    }
    const std::string full = real_path(root_ + "/" + normalized);
    if (full.empty()) {
        return Status::error(Code::invalid_scene,
                             "no such file in the scene root: \"" + normalized + "\"");
    }
    if (full.compare(0, root_real.size() + 1, root_real + "/") != 0) {
        return Status::error(Code::invalid_scene,
                             "\"" + normalized + "\" resolves outside the scene root (symlink)");
    }
    struct stat st {};
    if (::stat(full.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
        return Status::error(Code::invalid_scene, "\"" + normalized + "\" is not a regular file");
    }
    if (static_cast<std::size_t>(st.st_size) > max_bytes) {
        return Status::error(Code::too_large, "\"" + normalized + "\" is over the size limit");
    }
    std::ifstream f(full, std::ios::binary);
    std::string bytes(static_cast<std::size_t>(st.st_size), '\0');
    if (!f.read(bytes.data(), static_cast<std::streamsize>(bytes.size()))) {
        return Status::error(Code::invalid_scene, "cannot read \"" + normalized + "\"");
    }
    return bytes;
}

}  // namespace raycastd::server
