#include "io/digest.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include <fcntl.h>
#include <unistd.h>

namespace vkmech {

namespace {
uint64_t mix64(uint64_t z) {  // splitmix64 finalizer
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}
}  // namespace

Digest& Digest::bytes(const void* data, size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        uint64_t w;
        std::memcpy(&w, p + i, 8);
        a_ = mix64(a_ ^ w) + 0x9e3779b97f4a7c15ull;
        b_ = mix64(b_ + w * 0xff51afd7ed558ccdull) ^ (b_ >> 17);
    }
    uint64_t tail = 0;
    if (n > i) std::memcpy(&tail, p + i, n - i);  // never memcpy from null (an empty vector's data())
    tail ^= static_cast<uint64_t>(n - i) << 56;
    a_ = mix64(a_ ^ tail) + 0x9e3779b97f4a7c15ull;
    b_ = mix64(b_ + tail * 0xff51afd7ed558ccdull) ^ (b_ >> 17);
    return *this;
}

std::string Digest::hex() const {
    char buf[33];
    std::snprintf(buf, sizeof buf, "%016llx%016llx", static_cast<unsigned long long>(mix64(a_)),
                  static_cast<unsigned long long>(mix64(b_ ^ a_)));
    return buf;
}

std::string file_digest(const std::string& path, uint64_t* size) {
    int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw std::runtime_error("cannot read '" + path + "': " + std::strerror(errno));
    Digest d;
    uint64_t total = 0;
    // Whole 1 MiB blocks (a multiple of 8), so the digest does not depend on how reads split.
    std::vector<char> buf(1 << 20);
    size_t fill = 0;
    for (;;) {
        ssize_t k = ::read(fd, buf.data() + fill, buf.size() - fill);
        if (k < 0 && errno == EINTR) continue;
        if (k < 0) {
            int err = errno;
            ::close(fd);
            throw std::runtime_error("cannot read '" + path + "': " + std::strerror(err));
        }
        fill += static_cast<size_t>(k);
        total += static_cast<uint64_t>(k);
        if (k == 0 || fill == buf.size()) {
            if (fill > 0 || total == 0) d.bytes(buf.data(), fill);
            fill = 0;
            if (k == 0) break;
        }
    }
    ::close(fd);
    if (size) *size = total;
    return d.hex();
}

}  // namespace vkmech
