// SHA-256 (FIPS 180-4), for what must detect tampering rather than accidental
// damage: the sentinel pre-registration records (docs/descriptor.md §9). The
// 128-bit Digest (io/digest.hpp) stays the cache's and manifests' checksum.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace vkmech {

class Sha256 {
public:
    Sha256();
    Sha256& update(const void* data, size_t n);
    Sha256& update(const std::string& s) { return update(s.data(), s.size()); }
    // The digest as 64 lowercase hex digits. Finishes the hash: call once.
    std::string hex();

private:
    void block(const uint8_t* p);
    uint32_t h_[8];
    uint8_t buf_[64];
    size_t buf_len_ = 0;
    uint64_t total_ = 0;  // bytes
};

// SHA-256 of `s` (hex).
std::string sha256_hex(const std::string& s);
// SHA-256 of a whole file's bytes (hex), streamed; throws std::runtime_error
// naming the file when it cannot be read.
std::string sha256_file(const std::string& path);

}  // namespace vkmech
