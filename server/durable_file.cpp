#include "server/durable_file.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fcntl.h>
#include <unistd.h>

namespace raycastd::server {

namespace fs = std::filesystem;

namespace {

bool fail(IoError& error, const std::string& what, const fs::path& path) {
    error.code = errno;
    error.message = what + " " + path.string() + ": " + std::strerror(errno);
    return false;
}

}  // namespace

bool IoError::storage_refused() const {
    return code == ENOSPC || code == EDQUOT || code == EROFS || code == EACCES || code == EPERM ||
           code == EFBIG;
}

bool write_synced(const fs::path& path, std::string_view bytes, IoError& error) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0)
        return fail(error, "cannot create", path);
    std::size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            fail(error, "cannot write", path);
            ::close(fd);
            return false;
        }
        done += static_cast<std::size_t>(n);
    }
    if (::fsync(fd) != 0) {
        fail(error, "cannot fsync", path);
        ::close(fd);
        return false;
    }
    // close() reports write-back errors that fsync() missed on some file systems (NFS).
    if (::close(fd) != 0)
        return fail(error, "cannot close", path);
    return true;
}

bool sync_dir(const fs::path& dir, IoError& error) {
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0)
        return fail(error, "cannot open directory", dir);
    const bool ok = ::fsync(fd) == 0;
    if (!ok)
        fail(error, "cannot fsync directory", dir);
    ::close(fd);
    return ok;
}

bool rename_synced(const fs::path& from, const fs::path& to, IoError& error) {
    if (::rename(from.c_str(), to.c_str()) != 0)
        return fail(error, "cannot rename " + from.string() + " to", to);
    const fs::path to_dir = to.parent_path().empty() ? fs::path(".") : to.parent_path();
    const fs::path from_dir = from.parent_path().empty() ? fs::path(".") : from.parent_path();
    if (!sync_dir(to_dir, error))
        return false;
    return from_dir == to_dir || sync_dir(from_dir, error);
}

std::optional<std::string> read_file(const fs::path& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f)
        return std::nullopt;
    std::stringstream ss;
    ss << f.rdbuf();
    if (f.bad())
        return std::nullopt;
    return ss.str();
}

}  // namespace raycastd::server
