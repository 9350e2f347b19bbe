// A live view of a render in tev (or any viewer of tev's IPC protocol, as
// HDRView), as pbrt-v4's --display-server does: a TCP client written from the
// protocol's documented wire format (no tev code). Every packet is a
// little-endian uint32 of its whole length (these 4 bytes included), a type
// byte and its fields: strings are zero-terminated, integers 32-bit, channel
// offsets and strides 64-bit, pixels 32-bit floats.
//   CreateImage (4): grab focus (1 byte), name, width, height, channel count, names.
//   UpdateImageV3 (6): grab focus, name, channel count, names, x, y, width,
//     height, one offset and one stride per channel (in floats), the floats:
//     channel c of the tile's pixel i is data[offset[c] + i * stride[c]].
// A viewer that is absent, refuses or goes away costs a warning, never the
// render: the client then stops sending.
#pragma once

#include "io/exr.hpp"

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace vkmech {

class DisplayClient {
public:
    // Connects to "host:port" (1 s at most). A failure is remembered as warning().
    DisplayClient(const std::string& address, std::string image_name);
    ~DisplayClient();
    DisplayClient(const DisplayClient&) = delete;
    DisplayClient& operator=(const DisplayClient&) = delete;

    bool connected() const { return fd_ >= 0; }
    // Why the client stopped (empty while connected or before anything failed).
    const std::string& warning() const { return warning_; }

    // The image as it stands: the first call creates it with these channels; every call sends
    // the tiles (kTile x kTile) whose values changed since the last one sent. Unless `force`, a
    // call within kInterval of the last sent is skipped. Returns whether anything was sent.
    bool update(int width, int height, const std::vector<ExrChannel>& channels, bool force);
    // A second image on the same connection, sent whole once: "<image name> <what>" (render --adaptive:
    // the pilot, the allocation map). Returns whether it was sent; a failure ends the connection.
    bool send_snapshot(const std::string& what, int width, int height, const std::vector<ExrChannel>& channels);
    // Whether update(..., force) would send now (connected, and forced or past the interval):
    // callers skip building the channels otherwise.
    bool due(bool force) const {
        return fd_ >= 0 && (force || !created_ || std::chrono::steady_clock::now() - last_ >= kInterval);
    }

    static constexpr int kTile = 64;
    static constexpr std::chrono::milliseconds kInterval{250};

private:
    bool send_bytes(const std::vector<uint8_t>& packet);
    void fail(const std::string& why);

    int fd_ = -1;
    std::string address_, name_, warning_;
    bool created_ = false;
    int width_ = 0, height_ = 0;
    std::vector<std::string> names_;
    std::vector<std::vector<float>> sent_;  // per channel, the values the viewer holds
    std::chrono::steady_clock::time_point last_{};
};

// The packets (the tests decode them with their own reader).
std::vector<uint8_t> tev_create_image(const std::string& name, int width, int height,
                                      const std::vector<std::string>& channels);
// Tile (x, y, w, h) of full-image channel planes `planes` (width `image_width`).
std::vector<uint8_t> tev_update_image(const std::string& name, const std::vector<std::string>& channels,
                                      const std::vector<const std::vector<float>*>& planes, int image_width, int x,
                                      int y, int w, int h);

}  // namespace vkmech
