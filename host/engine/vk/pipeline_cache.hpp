// A VkPipelineCache persisted on disk, one file per device and driver, so a
// run does not recompile the compute pipelines an earlier run compiled.
//
// Where: $VKMECH_CACHE_DIR, else $XDG_CACHE_HOME/vkmech, else
// $HOME/.cache/vkmech (or the directory given by --pipeline-cache). File:
// pipelines-<vendorID>-<deviceID>-<driverVersion>-<pipelineCacheUUID>.bin (hex).
//
// The cache is an optimisation only: a missing, foreign, truncated or garbage
// file is ignored (one note on stderr); a directory that cannot be created or
// written disables saving (one note); rendering never fails because of it.
// Saves are atomic (temporary file + rename, io/atomic_file), and merge what
// another process saved meanwhile, so concurrent runs leave a valid file.
#pragma once

#include <vulkan/vulkan_raii.hpp>

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace vkmech::vk {

// What a cache blob must have been written by (Vulkan spec, "Pipeline Cache
// Header": VkPipelineCacheHeaderVersionOne).
struct PipelineCacheIdentity {
    uint32_t vendor_id = 0;
    uint32_t device_id = 0;
    std::array<uint8_t, VK_UUID_SIZE> uuid{};
};

// Checks the header of stored cache data against the device: header length
// >= 32 and within the data, VK_PIPELINE_CACHE_HEADER_VERSION_ONE, vendorID,
// deviceID and pipelineCacheUUID equal. Returns an empty string when the data
// may be handed to vkCreatePipelineCache, else why not. Needs no device.
std::string check_pipeline_cache_header(std::span<const uint8_t> data, const PipelineCacheIdentity& id);

// The default directory from the environment (see above); empty when neither
// VKMECH_CACHE_DIR, XDG_CACHE_HOME nor HOME is set.
std::string default_pipeline_cache_dir();

// pipelines-<vendor>-<device>-<driver>-<uuid>.bin, all hexadecimal.
std::string pipeline_cache_file_name(const PipelineCacheIdentity& id, uint32_t driver_version);

// Files larger than this are not read (a hostile file cannot exhaust memory).
inline constexpr uint64_t kMaxPipelineCacheBytes = uint64_t(1) << 30;

// Pipeline creations seen by a PipelineCache.
struct PipelineStats {
    uint32_t created = 0;  // pipelines created
    uint32_t hits = 0;     // of which the driver reported found in the application cache
    double seconds = 0.0;  // wall time spent creating them (and compiling, see Context::create_compute_pipeline)
    uint32_t reused = 0;   // pipelines not created: kept from earlier in the process (Context::kept_pipeline)
};

// The pipelines created between two snapshots of PipelineCache::stats().
PipelineStats operator-(const PipelineStats& after, const PipelineStats& before);

// How those pipelines were obtained, for messages and summaries: "cache hit"
// (the driver reported every one found in the cache), "cache miss", "cache off",
// or "reused in this process" when none was created and one was kept from earlier. A miss may still be fast: drivers
// keep their own shader caches (Mesa's in ~/.cache/mesa_shader_cache*), which this one does not see.
std::string pipeline_cache_outcome(const PipelineStats& s, bool cache_enabled);

// The validation messenger's tally (vk::Context). While `expecting` is above 0, a call runs that may
// make the layer speak for a reason vkmech handles (the best-effort merge of a cache file another run
// saved, which a driver may refuse): those messages are printed as expected and not counted.
struct MessageTally {
    std::atomic<uint32_t> count{0};
    std::atomic<int> expecting{0};
};

class PipelineCache {
public:
    // `dir` empty: no VkPipelineCache at all (`--pipeline-cache off`).
    // Otherwise loads <dir>/<file name> when it is valid for this device.
    PipelineCache(const ::vk::raii::Device& device, const ::vk::raii::PhysicalDevice& physical, const std::string& dir,
                  MessageTally* messages = nullptr);
    ~PipelineCache();
    PipelineCache(const PipelineCache&) = delete;
    PipelineCache& operator=(const PipelineCache&) = delete;

    // VK_NULL_HANDLE when disabled.
    ::vk::PipelineCache handle() const;
    const ::vk::raii::PipelineCache* raii() const { return cache_.get(); }
    bool enabled() const { return cache_ != nullptr; }
    // The cache file ("" when disabled).
    const std::string& path() const { return path_; }
    // Bytes of valid data loaded from the file at start (0: started empty).
    size_t loaded_bytes() const { return loaded_bytes_; }

    // Writes the cache to disk when the file is missing or invalid or the
    // cache grew since the load or the last save, merging in what is on disk
    // now (another run's pipelines). Never throws: a failure is noted once on stderr
    // and disables further saves.
    void save();

    // Accounting for Context::create_compute_pipeline.
    void record(double seconds, bool hit);
    void record_reuse() { stats_.reused += 1; }
    void add_seconds(double seconds) { stats_.seconds += seconds; }
    const PipelineStats& stats() const { return stats_; }

private:
    std::vector<uint8_t> read_valid_file(bool quiet) const;
    void note(const std::string& what) const;

    const ::vk::raii::Device* device_ = nullptr;
    MessageTally* messages_ = nullptr;  // the context's, or none
    PipelineCacheIdentity id_;
    std::unique_ptr<::vk::raii::PipelineCache> cache_;
    std::string path_;
    size_t loaded_bytes_ = 0;
    size_t saved_bytes_ = 0;  // size of the data at load or last save
    bool can_save_ = false;
    bool file_valid_ = false;  // the file on disk holds our data (loaded or saved)
    PipelineStats stats_;
};

}  // namespace vkmech::vk
