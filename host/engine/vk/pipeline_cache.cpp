#include "vk/pipeline_cache.hpp"

#include "io/atomic_file.hpp"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>

namespace fs = std::filesystem;

namespace vkmech::vk {

namespace {

// The spec writes every header field least significant byte first,
// whatever the host's byte order.
uint32_t read_le32(const uint8_t* p) {
    return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

std::string hex(uint32_t v) {
    char b[16];
    std::snprintf(b, sizeof b, "%x", v);
    return b;
}

std::string env(const char* name) {
    const char* v = std::getenv(name);
    return v ? std::string(v) : std::string();
}

}  // namespace

std::string check_pipeline_cache_header(std::span<const uint8_t> data, const PipelineCacheIdentity& id) {
    constexpr size_t kHeader = 16 + VK_UUID_SIZE;  // sizeof(VkPipelineCacheHeaderVersionOne)
    if (data.empty()) return "empty file";
    if (data.size() < kHeader)
        return "truncated header (" + std::to_string(data.size()) + " bytes, need " + std::to_string(kHeader) + ")";
    const uint32_t header_size = read_le32(data.data());
    if (header_size < kHeader || header_size > data.size())
        return "bad header length " + std::to_string(header_size) + " (file of " + std::to_string(data.size()) +
               " bytes)";
    const uint32_t version = read_le32(data.data() + 4);
    if (version != VK_PIPELINE_CACHE_HEADER_VERSION_ONE) return "unknown header version " + std::to_string(version);
    const uint32_t vendor = read_le32(data.data() + 8), device = read_le32(data.data() + 12);
    if (vendor != id.vendor_id)
        return "written for vendor 0x" + hex(vendor) + ", this device is 0x" + hex(id.vendor_id);
    if (device != id.device_id)
        return "written for device 0x" + hex(device) + ", this device is 0x" + hex(id.device_id);
    if (std::memcmp(data.data() + 16, id.uuid.data(), VK_UUID_SIZE) != 0)
        return "written by another driver build (pipelineCacheUUID differs)";
    return {};
}

std::string default_pipeline_cache_dir() {
    if (std::string d = env("VKMECH_CACHE_DIR"); !d.empty()) return d;
    if (std::string d = env("XDG_CACHE_HOME"); !d.empty()) return (fs::path(d) / "vkmech").string();
    if (std::string d = env("HOME"); !d.empty()) return (fs::path(d) / ".cache" / "vkmech").string();
    return {};
}

std::string pipeline_cache_file_name(const PipelineCacheIdentity& id, uint32_t driver_version) {
    std::string uuid;
    for (uint8_t b : id.uuid) {
        char h[3];
        std::snprintf(h, sizeof h, "%02x", b);
        uuid += h;
    }
    return "pipelines-" + hex(id.vendor_id) + "-" + hex(id.device_id) + "-" + hex(driver_version) + "-" + uuid + ".bin";
}

PipelineStats operator-(const PipelineStats& a, const PipelineStats& b) {
    return {a.created - b.created, a.hits - b.hits, a.seconds - b.seconds, a.reused - b.reused};
}

std::string pipeline_cache_outcome(const PipelineStats& s, bool cache_enabled) {
    if (s.created == 0 && s.reused > 0) return "reused in this process";
    if (!cache_enabled) return "cache off";
    return s.created > 0 && s.hits == s.created ? "cache hit" : "cache miss";
}

PipelineCache::PipelineCache(const ::vk::raii::Device& device, const ::vk::raii::PhysicalDevice& physical,
                             const std::string& dir, MessageTally* messages)
    : device_(&device), messages_(messages) {
    const auto props = physical.getProperties();
    id_.vendor_id = props.vendorID;
    id_.device_id = props.deviceID;
    std::memcpy(id_.uuid.data(), props.pipelineCacheUUID.data(), VK_UUID_SIZE);
    if (dir.empty()) return;  // off

    path_ = (fs::path(dir) / pipeline_cache_file_name(id_, props.driverVersion)).string();
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec)
        note("cannot create directory '" + dir + "' (" + ec.message() + "); compiling without a stored cache");
    else
        can_save_ = true;

    std::vector<uint8_t> data = ec ? std::vector<uint8_t>{} : read_valid_file(/*quiet=*/false);
    try {
        cache_ = std::make_unique<::vk::raii::PipelineCache>(
            device, ::vk::PipelineCacheCreateInfo{.initialDataSize = data.size(), .pInitialData = data.data()});
        loaded_bytes_ = data.size();
        file_valid_ = !data.empty();
    } catch (const std::exception& e) {
        // The header matched but the driver refused the body: start empty.
        note("ignoring '" + path_ + "': the driver refused it (" + e.what() + ")");
        cache_ = std::make_unique<::vk::raii::PipelineCache>(device, ::vk::PipelineCacheCreateInfo{});
    }
    saved_bytes_ = cache_->getData().size();
}

PipelineCache::~PipelineCache() = default;

::vk::PipelineCache PipelineCache::handle() const { return cache_ ? **cache_ : ::vk::PipelineCache{}; }

void PipelineCache::note(const std::string& what) const {
    std::fprintf(stderr, "vkmech: pipeline cache: %s\n", what.c_str());
}

std::vector<uint8_t> PipelineCache::read_valid_file(bool quiet) const {
    std::error_code ec;
    if (!fs::exists(path_, ec)) return {};
    const uintmax_t size = fs::file_size(path_, ec);
    if (ec) {
        if (!quiet) note("ignoring '" + path_ + "': " + ec.message());
        return {};
    }
    if (size > kMaxPipelineCacheBytes) {
        if (!quiet) note("ignoring '" + path_ + "': " + std::to_string(size) + " bytes, more than the 1 GiB limit");
        return {};
    }
    std::vector<uint8_t> data(static_cast<size_t>(size));
    std::ifstream in(path_, std::ios::binary);
    in.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size()));
    if (!in || in.gcount() != static_cast<std::streamsize>(data.size())) {
        // Replaced or truncated while we read it.
        if (!quiet) note("ignoring '" + path_ + "': cannot read it whole");
        return {};
    }
    if (std::string why = check_pipeline_cache_header(data, id_); !why.empty()) {
        if (!quiet) note("ignoring '" + path_ + "': " + why + "; starting empty (the next save replaces it)");
        return {};
    }
    return data;
}

void PipelineCache::save() {
    if (!cache_ || !can_save_) return;
    try {
        // Nothing new since a valid file was loaded or saved: leave it alone.
        // (Some drivers, lavapipe among them, store nothing but the header;
        // the file is then written once.)
        if (file_valid_ && cache_->getData().size() <= saved_bytes_) return;
        // Keep what another run saved since we loaded (best effort).
        if (std::vector<uint8_t> disk = read_valid_file(/*quiet=*/true); !disk.empty()) {
            // A driver may refuse another process's data (the NVIDIA driver did, under the GPU suite's
            // parallel processes), and the validation layer then says so: expected, not counted.
            if (messages_) messages_->expecting.fetch_add(1);
            try {
                ::vk::raii::PipelineCache theirs(*device_, ::vk::PipelineCacheCreateInfo{.initialDataSize = disk.size(),
                                                                                         .pInitialData = disk.data()});
                cache_->merge(*theirs);
            } catch (const std::exception&) {
                // Their file is not mergeable: ours replaces it.
            }
            if (messages_) messages_->expecting.fetch_sub(1);
        }
        std::vector<uint8_t> data = cache_->getData();
        write_file_atomic(path_, std::string(data.begin(), data.end()));
        saved_bytes_ = data.size();
        file_valid_ = true;
    } catch (const std::exception& e) {
        note(std::string(e.what()) + "; continuing without saving the cache");
        can_save_ = false;
    }
}

void PipelineCache::record(double seconds, bool hit) {
    stats_.created += 1;
    stats_.hits += hit ? 1 : 0;
    stats_.seconds += seconds;
}

}  // namespace vkmech::vk
