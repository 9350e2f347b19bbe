// On-disk cache of study renders (issue 4): one file per render, named by a
// digest of everything that determines it — the flattened scene (geometry,
// materials, emitters, textures, camera, integrator settings, so -D values and
// included files count), film size, spp, seed, estimator, batch size,
// traversal, device and the code (SPIR-V and a format version). Files are
// written atomically, so an interrupted study keeps every finished render and
// never sees a partial one.
//
// Integrity (issue 10, cache format 2): every cache file — a frame
// `<key>.frame`, and the allocation study's side files `<key>.frame.pool` and
// `<key>.frame.pilot` — is a sealed container: magic, format version, kind,
// the key it was stored under, the payload's size and its 128-bit digest, then
// the payload. A file whose key is not its name's, whose digest or size does
// not match, that is truncated, or whose frame holds a non-finite statistic is
// damaged: the study warns naming it, removes it and renders it again; it is
// never used. `vkmech verify cache DIR` checks a whole cache.
#pragma once

#include "io/digest.hpp"
#include "render/frame.hpp"
#include "render/gpu_scene.hpp"

#include <cstdint>
#include <optional>
#include <string>

namespace vkmech {

// Digest of the rendered content of a scene variant at its film size.
std::string scene_digest(const Scene& scene, const SceneArrays& arrays);

struct CacheKeyParts {
    std::string scene_digest;
    int width = 0, height = 0;
    uint32_t spp = 0, seed = 0, estimator = 0, batch_spp = 0;
    std::string traversal, device, code_digest;
    uint32_t end_vertex = 0;  // EndVertex (docs/descriptor.md §2 reading)
};
std::string cache_key(const CacheKeyParts& k);

// Thrown for a cache file that must not be used; what() names the file and the reason.
class CacheFileError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

class RenderCache {
public:
    explicit RenderCache(std::string dir) : dir_(std::move(dir)) {}
    const std::string& dir() const { return dir_; }
    // `<dir>/<key>.frame`, or `<dir>/<key>.frame.<kind>` for the side files (kind "pool", "pilot").
    std::string path(const std::string& key, const std::string& kind = "frame") const;
    bool contains(const std::string& key) const;
    // Throws CacheFileError naming the file when it is unreadable, damaged or not this key's.
    Frame load(const std::string& key) const;
    // The frame when present and sound; a damaged file is reported on stderr
    // (warning naming the file and the reason), removed, and nullopt returned.
    std::optional<Frame> try_load(const std::string& key) const;
    void store(const std::string& key, const Frame& frame, const std::string& description) const;
    // Side files: a payload sealed like a frame (same checks, same warnings).
    std::optional<std::string> try_load_payload(const std::string& key, const std::string& kind) const;
    void store_payload(const std::string& key, const std::string& kind, const std::string& payload) const;

private:
    std::string dir_;
};

// Serialization of a Frame (exposed for tests): the payload of a ".frame" file.
std::string serialize_frame(const Frame& frame, const std::string& description);
// Throws CacheFileError naming `where`; *used (optional) receives the bytes read.
Frame deserialize_frame(const std::string& bytes, const std::string& where, size_t* used = nullptr);

// The allocation study's pilot side file: a frame and its median-of-means variances.
std::string serialize_pilot(const Frame& frame, const std::vector<double>& mom_var);
Frame deserialize_pilot(const std::string& payload, const std::string& where, std::vector<double>* mom_var);

// The sealed container (format 2) around a payload, and its check: returns the
// payload or throws CacheFileError("render cache file '<where>': <reason>").
std::string seal_cache_file(const std::string& kind, const std::string& key, const std::string& payload);
std::string open_cache_file(const std::string& bytes, const std::string& kind, const std::string& key,
                            const std::string& where);

// `vkmech verify cache DIR`: every file of a cache directory checked.
struct CacheVerifyReport {
    std::vector<std::string> good;
    std::vector<std::pair<std::string, std::string>> bad;    // file, reason
    std::vector<std::pair<std::string, std::string>> stale;  // file, why (old format, leftover temporary)
};
CacheVerifyReport verify_cache_dir(const std::string& dir);

}  // namespace vkmech
