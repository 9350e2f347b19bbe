// On-disk cache of study renders: one file per render, named by a
// digest of everything that determines it — the flattened scene (geometry,
// materials, emitters, textures, camera, integrator settings, so -D values and
// included files count), film size, spp, seed, estimator, batch size,
// traversal, device and the code (SPIR-V and a format version). Files are
// written atomically, so an interrupted study keeps every finished render and
// never sees a partial one.
//
// Integrity (docs/reliability.md; cache format 3 since the payloads became typed,
// versioned blobs): every cache file — a frame
// `<key>.frame`, and the allocation study's side files `<key>.frame.pool` and
// `<key>.frame.pilot` and `<key>.frame.pilot-samples` — is a sealed container: magic, format version, kind,
// the key it was stored under, the payload's size and its 128-bit digest, then
// the payload. A file whose key is not its name's, whose digest or size does
// not match, that is truncated, or whose frame holds a non-finite statistic is
// damaged: the study warns naming it, removes it and renders it again; it is
// never used. `vkmech verify cache DIR` checks a whole cache.
#pragma once

#include "allocation/plan.hpp"
#include "io/digest.hpp"
#include "render/frame.hpp"
#include "render/gpu_scene.hpp"

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace vkmech {

// Digest of the rendered content of a scene variant at its film size: every
// array the shaders read, in the triangle order of the traversal the arrays
// were flattened for (flatten_scene(scene, traversal)): the software BVH's
// tree order, or ray query's scene order.
std::string scene_digest(const Scene& scene, const SceneArrays& arrays);

struct CacheKeyParts {
    std::string scene_digest;
    int width = 0, height = 0;
    uint32_t spp = 0, seed = 0, estimator = 0, batch_spp = 0;
    std::string traversal, device, code_digest;
    uint32_t end_vertex = 0;  // EndVertex (docs/descriptor.md §2 reading)
    std::string taxonomy;     // a user taxonomy's compiled words' digest; "" for the buckets
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
    // The allocation study's side files, parsed: a damaged or unsound one is
    // warned about, removed and not returned, like a frame.
    std::optional<Pilot> try_load_pilot(const std::string& key) const;
    void store_pilot(const std::string& key, const Pilot& pilot) const;
    std::optional<SamplePool> try_load_pool(const std::string& key) const;
    std::optional<PilotSamples> try_load_pilot_samples(const std::string& key) const;
    void store_pilot_samples(const std::string& key, const PilotSamples& s) const;
    void store_pool(const std::string& key, const SamplePool& pool) const;

private:
    std::string dir_;
};

// The payloads' versioned blob format: a record of one type ("frame",
// "pilot", "pool") and version, then its fields, each a fixed-size value, a
// counted array or a counted string. A reader checks the type and version
// before reading a field, every count against the bytes left, and that
// nothing trails the last field; a failure throws CacheFileError naming the
// file. A new field means a new version of its type, read or refused by name.
class BlobWriter {
public:
    BlobWriter(const std::string& type, uint32_t version);
    template <class T>
    BlobWriter& pod(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        out_.append(reinterpret_cast<const char*>(&v), sizeof v);
        return *this;
    }
    template <class T>
    BlobWriter& array(const std::vector<T>& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        pod(static_cast<uint64_t>(v.size()));
        out_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
        return *this;
    }
    BlobWriter& str(const std::string& s);
    const std::string& bytes() const { return out_; }

private:
    std::string out_;
};

class BlobReader {
public:
    // Throws CacheFileError("render cache file '<where>': ...") unless `bytes`
    // holds a blob of `type` at `version`.
    BlobReader(const std::string& bytes, const std::string& type, uint32_t version, std::string where);
    template <class T>
    T pod() {
        static_assert(std::is_trivially_copyable_v<T>);
        T v;
        take(&v, sizeof v);
        return v;
    }
    template <class T>
    std::vector<T> array() {
        static_assert(std::is_trivially_copyable_v<T>);
        const uint64_t n = pod<uint64_t>();
        if (n > left() / sizeof(T))
            fail("truncated (an array of " + std::to_string(n) + " values, " + std::to_string(left()) + " bytes left)");
        std::vector<T> v(n);
        take(v.data(), n * sizeof(T));
        return v;
    }
    std::string str();
    void end() const;  // throws unless every byte was read
    [[noreturn]] void fail(const std::string& what) const;

private:
    void take(void* dst, size_t n);
    size_t left() const { return b_.size() - pos_; }
    const std::string& b_;
    size_t pos_ = 0;
    std::string where_;
};

// Serialization of a Frame (exposed for tests): the payload of a ".frame" file,
// a "frame" blob. deserialize_frame also refuses a frame with a non-finite statistic.
std::string serialize_frame(const Frame& frame, const std::string& description);
Frame deserialize_frame(const std::string& bytes, const std::string& where);

// The allocation study's pilot side file: a "pilot" blob holding the pilot's
// frame blob and its median-of-means variances (none, or one per pixel).
std::string serialize_pilot(const Frame& frame, const std::vector<double>& mom_var);
Pilot deserialize_pilot(const std::string& payload, const std::string& where);

// The allocation study's per-sample pilot side file: a "pilot-samples" blob
// (sample and pixel counts, the luminance of every sample, NaN for one
// counted out), checked for consistent sizes and no infinite value.
std::string serialize_pilot_samples(const PilotSamples& s);
PilotSamples deserialize_pilot_samples(const std::string& payload, const std::string& where);

// The allocation study's pool side file: a "pool" blob (frame and pixel counts,
// the samples, the oracle variances), checked for consistent sizes, finite
// values and 0/1 finite flags.
std::string serialize_pool(const SamplePool& pool);
SamplePool deserialize_pool(const std::string& payload, const std::string& where);

// The sealed container (format 3) around a payload, and its check: returns the
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
