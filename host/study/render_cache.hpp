// On-disk cache of study renders (issue 4): one file per render, named by a
// digest of everything that determines it — the flattened scene (geometry,
// materials, emitters, textures, camera, integrator settings, so -D values and
// included files count), film size, spp, seed, estimator, batch size,
// traversal, device and the code (SPIR-V and a format version). Files are
// written atomically, so an interrupted study keeps every finished render and
// never sees a partial one.
#pragma once

#include "render/frame.hpp"
#include "render/gpu_scene.hpp"

#include <cstdint>
#include <optional>
#include <string>

namespace vkmech {

// 128-bit non-cryptographic digest (two independent 64-bit lanes).
class Digest {
public:
    Digest& bytes(const void* data, size_t n);
    template <class T> Digest& pod(const T& v) { return bytes(&v, sizeof(T)); }
    template <class T> Digest& vec(const std::vector<T>& v) {
        pod(static_cast<uint64_t>(v.size()));
        return bytes(v.data(), v.size() * sizeof(T));
    }
    Digest& str(const std::string& s) {
        pod(static_cast<uint64_t>(s.size()));
        return bytes(s.data(), s.size());
    }
    std::string hex() const;

private:
    uint64_t a_ = 0x243f6a8885a308d3ull, b_ = 0x13198a2e03707344ull;
};

// Digest of the rendered content of a scene variant at its film size.
std::string scene_digest(const Scene& scene, const SceneArrays& arrays);

struct CacheKeyParts {
    std::string scene_digest;
    int width = 0, height = 0;
    uint32_t spp = 0, seed = 0, estimator = 0, batch_spp = 0;
    std::string traversal, device, code_digest;
    uint32_t end_vertex = 0;  // EndVertex (SPEC §2 reading)
};
std::string cache_key(const CacheKeyParts& k);

class RenderCache {
public:
    explicit RenderCache(std::string dir) : dir_(std::move(dir)) {}
    const std::string& dir() const { return dir_; }
    std::string path(const std::string& key) const;
    bool contains(const std::string& key) const;
    // Throws std::runtime_error naming the file when it is unreadable or corrupt.
    Frame load(const std::string& key) const;
    void store(const std::string& key, const Frame& frame, const std::string& description) const;

private:
    std::string dir_;
};

// Serialization of a Frame (exposed for tests).
std::string serialize_frame(const Frame& frame, const std::string& description);
Frame deserialize_frame(const std::string& bytes, const std::string& where);

}  // namespace vkmech
