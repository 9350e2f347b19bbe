// Vulkan instance, physical-device choice and logical device (RAII).
#pragma once

#include "vk/pipeline_cache.hpp"

#include <vulkan/vulkan_raii.hpp>

#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace vkmech::vk {

// A Vulkan failure: names the call that failed (docs/architecture.md, "Errors say what, where and what to do").
class VulkanError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Throws VulkanError("<call>: <VkResult>") unless r is eSuccess.
void check(::vk::Result r, const char* call);
void check(VkResult r, const char* call);

struct DeviceInfo {
    uint32_t index = 0;
    std::string name;
    std::string type;  // discrete, integrated, virtual, cpu, other
    std::string driver;
    uint32_t api_version = 0;
    bool ray_query = false;  // VK_KHR_ray_query + VK_KHR_acceleration_structure
    uint32_t max_workgroup_invocations = 0;
    bool compute_subgroup_ballot = false;  // subgroupBallot and friends in compute shaders
    uint64_t max_storage_buffer_range = 0;
    uint64_t device_local_bytes = 0;
};

// Which kernel the device runs (docs/gpu.md, "Two kernels"): the software
// traversal's tree and reads, and how work is scheduled. `Cpu`, tuned on
// lavapipe: the 4-wide quantized tree read through texel buffers, the stack's
// top in registers, claimed pixels, ray slices. `Gpu`, measured on NVIDIA: the
// binary tree and the scene arrays in storage buffers, a plain stack, 8 x 8
// tiles in image order. `Auto` picks by the device's type (a CPU device gets
// `Cpu`, every other `Gpu`); the environment's VKMECH_KERNEL overrides Auto.
enum class KernelClass { Auto, Cpu, Gpu };
const char* to_string(KernelClass k);
KernelClass parse_kernel_class(const std::string& s);  // "auto", "cpu", "gpu"; throws std::invalid_argument

struct ContextOptions {
    std::optional<uint32_t> device_index;  // --device N
    bool validation = false;               // enable VK_LAYER_KHRONOS_validation when present
    bool want_ray_query = true;            // enable ray-query extensions when supported
    // The on-disk pipeline cache directory (vk/pipeline_cache.hpp): unset =
    // the default from the environment, "off" or "" = no cache.
    std::optional<std::string> pipeline_cache_dir;
    KernelClass kernel = KernelClass::Auto;  // --kernel
};

struct PipelineCore;  // vk/pipeline.hpp

class Context {
public:
    explicit Context(const ContextOptions& options = {});
    ~Context();
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    const ::vk::raii::Device& device() const { return *device_; }
    const ::vk::raii::PhysicalDevice& physical() const { return *physical_; }
    const ::vk::raii::Queue& queue() const { return *queue_; }
    uint32_t queue_family() const { return queue_family_; }
    const DeviceInfo& info() const { return info_; }
    // The kernel this device runs: Cpu or Gpu, never Auto (ContextOptions::kernel).
    KernelClass kernel() const { return kernel_; }
    bool ray_query_enabled() const { return ray_query_enabled_; }
    // VK_KHR_shader_clock's subgroup clock, enabled where the device has it: the
    // path tracer's counters variant times its phases with it.
    bool shader_clock_enabled() const { return shader_clock_enabled_; }
    bool validation_enabled() const { return validation_enabled_; }
    // Number of validation messages of severity warning or error seen so far.
    uint32_t validation_messages() const;

    // Records commands with `record`, submits them and waits.
    template <class F>
    void submit_and_wait(F&& record) const {
        ::vk::raii::CommandBuffer cmd = begin_one_shot();
        record(*cmd);
        end_one_shot(cmd);
    }

    // Creates a compute pipeline through the pipeline cache, timing it (and
    // the driver's compilation) into pipeline_cache().stats(), then saves the
    // cache so an interrupted run still leaves it on disk.
    ::vk::raii::Pipeline create_compute_pipeline(const ::vk::ComputePipelineCreateInfo& info) const;
    PipelineCache& pipeline_cache() const { return *pipeline_cache_; }

    // Compiled pipelines kept for reuse within this process (ComputePipeline): one made again from the same
    // SPIR-V, bindings, push-constant size and specialization takes the compiled one (a study makes the same
    // pipeline for every scene variant with the same features; lavapipe spends about a second on each
    // creation). kept_pipeline returns nullptr when none is kept; keep_pipeline holds at most kKeptPipelines,
    // dropping the least recently used (its users keep their own reference).
    static constexpr size_t kKeptPipelines = 32;
    std::shared_ptr<const PipelineCore> kept_pipeline(const std::string& key) const;
    void keep_pipeline(const std::string& key, std::shared_ptr<const PipelineCore> core) const;

    uint32_t find_memory_type(uint32_t type_bits, ::vk::MemoryPropertyFlags wanted,
                              ::vk::MemoryPropertyFlags fallback = {}) const;

    static std::vector<DeviceInfo> list_devices();

private:
    ::vk::raii::CommandBuffer begin_one_shot() const;
    void end_one_shot(::vk::raii::CommandBuffer& cmd) const;

    ::vk::raii::Context context_;
    std::unique_ptr<::vk::raii::Instance> instance_;
    std::unique_ptr<::vk::raii::DebugUtilsMessengerEXT> messenger_;
    std::unique_ptr<::vk::raii::PhysicalDevice> physical_;
    std::unique_ptr<::vk::raii::Device> device_;
    std::unique_ptr<::vk::raii::Queue> queue_;
    std::unique_ptr<::vk::raii::CommandPool> pool_;
    std::unique_ptr<::vk::raii::Fence> fence_;
    std::unique_ptr<PipelineCache> pipeline_cache_;  // destroyed before device_
    mutable std::mutex kept_mutex_;
    // Most recent first; cleared in ~Context, before the device.
    mutable std::list<std::pair<std::string, std::shared_ptr<const PipelineCore>>> kept_;
    uint32_t queue_family_ = 0;
    DeviceInfo info_;
    KernelClass kernel_ = KernelClass::Cpu;
    bool ray_query_enabled_ = false;
    bool shader_clock_enabled_ = false;
    bool validation_enabled_ = false;
    bool creation_feedback_ = false;  // VK_EXT_pipeline_creation_feedback enabled
    struct Messages;
    std::unique_ptr<Messages> messages_;
};

}  // namespace vkmech::vk
