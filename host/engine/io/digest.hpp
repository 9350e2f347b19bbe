// A 128-bit non-cryptographic digest (two independent 64-bit lanes of a
// splitmix64-style mix): cache keys, cache payload checksums and the output
// manifests' file checksums. It detects accidental damage (flipped bytes,
// truncation), not tampering.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace vkmech {

class Digest {
public:
    Digest& bytes(const void* data, size_t n);
    template <class T>
    Digest& pod(const T& v) {
        return bytes(&v, sizeof(T));
    }
    template <class T>
    Digest& vec(const std::vector<T>& v) {
        pod(static_cast<uint64_t>(v.size()));
        return bytes(v.data(), v.size() * sizeof(T));
    }
    Digest& str(const std::string& s) {
        pod(static_cast<uint64_t>(s.size()));
        return bytes(s.data(), s.size());
    }
    std::string hex() const;  // 32 hex digits

private:
    uint64_t a_ = 0x243f6a8885a308d3ull, b_ = 0x13198a2e03707344ull;
};

// Digest of a whole file's bytes (hex), streamed; throws std::runtime_error
// naming the file when it cannot be read.
std::string file_digest(const std::string& path, uint64_t* size = nullptr);

}  // namespace vkmech
