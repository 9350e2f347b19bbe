#include "scene/file_read.hpp"

#include "scene/scene.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace vkmech {

namespace {

std::string size_text(uint64_t bytes) {
    return bytes >= (uint64_t(1) << 20) ? std::to_string(bytes >> 20) + " MiB" : std::to_string(bytes) + " bytes";
}

[[noreturn]] void too_large(const std::string& path, const std::string& what, uint64_t max_bytes) {
    throw SceneError(path, 0,
                     what + " is larger than " + size_text(max_bytes) +
                         ", more than the loader accepts for it (a wrong file name?)");
}

// Closes the descriptor on every path out.
struct Fd {
    int fd;
    explicit Fd(int d) : fd(d) {}
    Fd(Fd&& o) noexcept : fd(o.fd) { o.fd = -1; }
    Fd(const Fd&) = delete;
    Fd& operator=(const Fd&) = delete;
    ~Fd() {
        if (fd >= 0) ::close(fd);
    }
};

// Opens `path` for reading if it is a regular file.
Fd open_regular(const std::string& path, const std::string& what, struct stat& st) {
    // O_NONBLOCK: opening a FIFO must not wait for a writer; fstat then
    // refuses it like any other file that is not regular.
    Fd f{::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)};
    if (f.fd < 0) throw SceneError(path, 0, "cannot open " + what + " (" + std::strerror(errno) + ")");
    if (::fstat(f.fd, &st) != 0) throw SceneError(path, 0, "cannot stat " + what + " (" + std::strerror(errno) + ")");
    if (!S_ISREG(st.st_mode))
        throw SceneError(path, 0,
                         what + " is not a regular file (" +
                             (S_ISDIR(st.st_mode) ? "a directory" : "a device, pipe or socket") +
                             "); give the path of a file");
    return f;
}

}  // namespace

void require_regular_file(const std::string& path, const std::string& what) {
    struct stat st {};
    open_regular(path, what, st);
}

std::string read_regular_file(const std::string& path, const std::string& what, uint64_t max_bytes) {
    struct stat st {};
    Fd f = open_regular(path, what, st);
    if (static_cast<uint64_t>(st.st_size) > max_bytes) too_large(path, what, max_bytes);
    std::string data;
    data.resize(static_cast<size_t>(st.st_size));
    size_t got = 0;
    for (;;) {
        if (got == data.size()) {
            // The size stat gave may be stale (or 0, as in /proc): read on.
            if (data.size() >= max_bytes) {
                char probe;
                if (::read(f.fd, &probe, 1) > 0) too_large(path, what, max_bytes);
                break;
            }
            data.resize(std::min<uint64_t>(max_bytes, std::max<uint64_t>(2 * data.size(), 4096)));
        }
        ssize_t n = ::read(f.fd, data.data() + got, data.size() - got);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) throw SceneError(path, 0, "cannot read " + what + " (" + std::strerror(errno) + ")");
        if (n == 0) break;
        got += static_cast<size_t>(n);
    }
    data.resize(got);
    return data;
}

}  // namespace vkmech
