#include "io/atomic_file.hpp"

#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <system_error>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace fs = std::filesystem;

namespace vkmech {

namespace {

std::string errno_text(const char* what, int err) { return std::string(what) + ": " + std::strerror(err); }

// Best effort: make the rename itself durable. Failure here is not an error
// (some file systems do not support fsync on directories).
void fsync_directory(const fs::path& dir) {
    const std::string d = dir.empty() ? std::string(".") : dir.string();
    int fd = ::open(d.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return;
    (void)::fsync(fd);
    (void)::close(fd);
}

}  // namespace

std::string atomic_temp_path(const std::string& path) {
    return path + ".host-" + temp_host_name() + ".tmp-" + std::to_string(::getpid());
}

std::string temp_host_name() {
    static const std::string name = [] {
        char b[256] = {};
        if (::gethostname(b, sizeof b - 1) != 0 || b[0] == 0) return std::string("unknown");
        std::string s(b);
        for (char& c : s)  // a file-name-safe spelling
            if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') c = '_';
        return s;
    }();
    return name;
}

void write_all_fd(int fd, const void* data, size_t n) {
    const char* p = static_cast<const char*>(data);
    while (n > 0) {
        ssize_t k = ::write(fd, p, n);
        if (k < 0) {
            if (errno == EINTR) continue;
            throw std::runtime_error(errno_text("write failed", errno));
        }
        if (k == 0) throw std::runtime_error("write failed: no progress");
        p += k;
        n -= static_cast<size_t>(k);
    }
}

void write_file_atomic_with(const std::string& path,
                            const std::function<void(int fd, const std::string& tmp_path)>& fill) {
    const std::string tmp = atomic_temp_path(path);
    int fd = -1;
    bool created = false;
    try {
        if (path.empty()) throw std::runtime_error("empty path");
        const fs::path parent = fs::path(path).parent_path();
        if (!parent.empty()) {
            std::error_code ec;
            fs::create_directories(parent, ec);
            if (ec) throw std::runtime_error("cannot create directory '" + parent.string() + "': " + ec.message());
        }
        fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
        if (fd < 0) throw std::runtime_error(errno_text(("cannot create temporary '" + tmp + "'").c_str(), errno));
        created = true;
        fill(fd, tmp);
        if (::fsync(fd) != 0) throw std::runtime_error(errno_text("fsync failed", errno));
        const int rc = ::close(fd);
        fd = -1;
        if (rc != 0) throw std::runtime_error(errno_text("close failed", errno));
        if (::rename(tmp.c_str(), path.c_str()) != 0)
            throw std::runtime_error(errno_text(("cannot rename '" + tmp + "' to it").c_str(), errno));
        created = false;
        fsync_directory(parent);
    } catch (const std::exception& e) {
        if (fd >= 0) (void)::close(fd);
        if (created) (void)::unlink(tmp.c_str());
        throw std::runtime_error("cannot write '" + path + "': " + e.what());
    } catch (...) {
        if (fd >= 0) (void)::close(fd);
        if (created) (void)::unlink(tmp.c_str());
        throw std::runtime_error("cannot write '" + path + "': unknown error");
    }
}

void write_file_atomic(const std::string& path, const std::string& bytes) {
    write_file_atomic_with(path, [&](int fd, const std::string&) { write_all_fd(fd, bytes.data(), bytes.size()); });
}

}  // namespace vkmech
