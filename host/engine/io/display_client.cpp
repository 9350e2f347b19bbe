#include "io/display_client.hpp"

#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/types.h>
#include <unistd.h>

#include <fcntl.h>
#include <cerrno>
#include <cstring>

namespace vkmech {

namespace {

struct Writer {
    std::vector<uint8_t> bytes = {0, 0, 0, 0};  // the length, filled in by finish()
    void u8(uint8_t v) { bytes.push_back(v); }
    void u32(uint32_t v) {
        for (int k = 0; k < 4; ++k) bytes.push_back(static_cast<uint8_t>(v >> (8 * k)));
    }
    void u64(uint64_t v) {
        for (int k = 0; k < 8; ++k) bytes.push_back(static_cast<uint8_t>(v >> (8 * k)));
    }
    void f32(float v) {
        uint32_t u;
        std::memcpy(&u, &v, 4);
        u32(u);
    }
    void str(const std::string& s) {
        bytes.insert(bytes.end(), s.begin(), s.end());
        bytes.push_back(0);
    }
    std::vector<uint8_t> finish() {
        const uint32_t n = static_cast<uint32_t>(bytes.size());
        for (int k = 0; k < 4; ++k) bytes[k] = static_cast<uint8_t>(n >> (8 * k));
        return std::move(bytes);
    }
};

constexpr uint8_t kCreateImage = 4, kUpdateImageV3 = 6;

}  // namespace

std::vector<uint8_t> tev_create_image(const std::string& name, int width, int height,
                                      const std::vector<std::string>& channels) {
    Writer w;
    w.u8(kCreateImage);
    w.u8(0);  // grab focus: no
    w.str(name);
    w.u32(static_cast<uint32_t>(width));
    w.u32(static_cast<uint32_t>(height));
    w.u32(static_cast<uint32_t>(channels.size()));
    for (const auto& c : channels) w.str(c);
    return w.finish();
}

std::vector<uint8_t> tev_update_image(const std::string& name, const std::vector<std::string>& channels,
                                      const std::vector<const std::vector<float>*>& planes, int image_width, int x,
                                      int y, int w, int h) {
    Writer p;
    p.u8(kUpdateImageV3);
    p.u8(0);
    p.str(name);
    p.u32(static_cast<uint32_t>(channels.size()));
    for (const auto& c : channels) p.str(c);
    for (int v : {x, y, w, h}) p.u32(static_cast<uint32_t>(v));
    // Planar: channel c's tile occupies floats [c * w * h, (c + 1) * w * h).
    const uint64_t pixels = static_cast<uint64_t>(w) * static_cast<uint64_t>(h);
    for (size_t c = 0; c < channels.size(); ++c) p.u64(c * pixels);
    for (size_t c = 0; c < channels.size(); ++c) p.u64(1);
    p.bytes.reserve(p.bytes.size() + 4 * pixels * channels.size());
    for (const auto* plane : planes)
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) p.f32((*plane)[static_cast<size_t>(y + j) * image_width + (x + i)]);
    return p.finish();
}

DisplayClient::DisplayClient(const std::string& address, std::string image_name)
    : address_(address), name_(std::move(image_name)) {
    const size_t colon = address.rfind(':');
    if (colon == std::string::npos || colon == 0 || colon + 1 == address.size()) {
        fail("'" + address + "' is not host:port");
        return;
    }
    const std::string host = address.substr(0, colon), port = address.substr(colon + 1);
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    addrinfo* res = nullptr;
    if (const int rc = ::getaddrinfo(host.c_str(), port.c_str(), &hints, &res); rc != 0) {
        fail(std::string("cannot resolve it: ") + ::gai_strerror(rc));
        return;
    }
    std::string why = "no address";
    for (addrinfo* a = res; a && fd_ < 0; a = a->ai_next) {
        const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
        if (fd < 0) continue;
        // Connect within 1 s (non-blocking, then poll), then block with a send timeout.
        const int flags = ::fcntl(fd, F_GETFL, 0);
        ::fcntl(fd, F_SETFL, flags | O_NONBLOCK);
        int rc = ::connect(fd, a->ai_addr, a->ai_addrlen);
        if (rc != 0 && errno == EINPROGRESS) {
            pollfd pfd{fd, POLLOUT, 0};
            rc = ::poll(&pfd, 1, 1000) == 1 ? 0 : -1;
            int err = rc == 0 ? 0 : ETIMEDOUT;
            socklen_t len = sizeof err;
            if (rc == 0) ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
            if (err != 0) {
                errno = err;
                rc = -1;
            }
        }
        if (rc != 0) {
            why = std::strerror(errno);
            ::close(fd);
            continue;
        }
        ::fcntl(fd, F_SETFL, flags);
        timeval tv{2, 0};  // a viewer that stops reading for 2 s is gone
        ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
        fd_ = fd;
    }
    ::freeaddrinfo(res);
    if (fd_ < 0) fail("cannot connect: " + why);
}

DisplayClient::~DisplayClient() {
    if (fd_ >= 0) ::close(fd_);
}

void DisplayClient::fail(const std::string& why) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    if (warning_.empty()) warning_ = "display server " + address_ + ": " + why + "; the render goes on without it";
}

bool DisplayClient::send_bytes(const std::vector<uint8_t>& packet) {
    size_t off = 0;
    while (off < packet.size()) {
        const ssize_t n = ::send(fd_, packet.data() + off, packet.size() - off, MSG_NOSIGNAL);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            fail(n < 0 ? std::string("lost: ") + std::strerror(errno) : std::string("lost"));
            return false;
        }
        off += static_cast<size_t>(n);
    }
    return true;
}

bool DisplayClient::update(int width, int height, const std::vector<ExrChannel>& channels, bool force) {
    if (fd_ < 0) return false;
    const auto now = std::chrono::steady_clock::now();
    if (!force && created_ && now - last_ < kInterval) return false;
    if (!created_) {
        width_ = width;
        height_ = height;
        for (const auto& c : channels) names_.push_back(c.name);
        if (!send_bytes(tev_create_image(name_, width, height, names_))) return false;
        sent_.assign(channels.size(), std::vector<float>(static_cast<size_t>(width) * height, 0.0f));
        created_ = true;
    }
    if (width != width_ || height != height_ || channels.size() != names_.size()) {
        fail("the image changed its size or channels");
        return false;
    }
    std::vector<const std::vector<float>*> planes;
    for (const auto& c : channels) planes.push_back(&c.data);
    bool any = false;
    for (int y = 0; y < height; y += kTile)
        for (int x = 0; x < width; x += kTile) {
            const int w = std::min(kTile, width - x), h = std::min(kTile, height - y);
            bool changed = false;
            for (size_t c = 0; c < channels.size() && !changed; ++c)
                for (int j = 0; j < h && !changed; ++j) {
                    const size_t row = static_cast<size_t>(y + j) * width + x;
                    changed = std::memcmp(&channels[c].data[row], &sent_[c][row], sizeof(float) * w) != 0;
                }
            if (!changed) continue;
            if (!send_bytes(tev_update_image(name_, names_, planes, width, x, y, w, h))) return false;
            for (size_t c = 0; c < channels.size(); ++c)
                for (int j = 0; j < h; ++j) {
                    const size_t row = static_cast<size_t>(y + j) * width + x;
                    std::memcpy(&sent_[c][row], &channels[c].data[row], sizeof(float) * w);
                }
            any = true;
        }
    last_ = now;
    return any;
}

bool DisplayClient::send_snapshot(const std::string& what, int width, int height,
                                  const std::vector<ExrChannel>& channels) {
    if (fd_ < 0) return false;
    // The snapshot's name: the image's own with `what` before its " (<pid>)".
    const size_t paren = name_.rfind(" (");
    const std::string name =
        paren == std::string::npos ? name_ + " " + what : name_.substr(0, paren) + " " + what + name_.substr(paren);
    std::vector<std::string> names;
    std::vector<const std::vector<float>*> planes;
    for (const auto& c : channels) {
        names.push_back(c.name);
        planes.push_back(&c.data);
    }
    if (!send_bytes(tev_create_image(name, width, height, names))) return false;
    for (int y = 0; y < height; y += kTile)
        for (int x = 0; x < width; x += kTile)
            if (!send_bytes(tev_update_image(name, names, planes, width, x, y, std::min(kTile, width - x),
                                             std::min(kTile, height - y))))
                return false;
    return true;
}

}  // namespace vkmech
