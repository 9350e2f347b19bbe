// A compute pipeline with one descriptor set of its own, push constants and
// specialization constants; the compiled pipeline and its layouts are shared
// with every other made from the same inputs in the process (PipelineCore).
#pragma once

#include "vk/context.hpp"

#include <cstdint>
#include <span>
#include <vector>

namespace vkmech::vk {

struct BindingDesc {
    uint32_t binding;
    ::vk::DescriptorType type;
};

struct SpecConstant {
    uint32_t id;
    uint32_t value;
};

// What ComputePipelines made from the same inputs share (Context::kept_pipeline): the compiled pipeline with
// the layouts it was created with; each ComputePipeline has its own descriptor set.
struct PipelineCore {
    std::unique_ptr<::vk::raii::DescriptorSetLayout> set_layout;
    std::unique_ptr<::vk::raii::PipelineLayout> layout;
    std::unique_ptr<::vk::raii::Pipeline> pipeline;
};

class ComputePipeline {
public:
    ComputePipeline(const Context& ctx, std::span<const uint32_t> spirv, std::vector<BindingDesc> bindings,
                    uint32_t push_constant_bytes, const std::vector<SpecConstant>& spec = {});

    void bind_buffer(uint32_t binding, ::vk::Buffer buffer, ::vk::DeviceSize size = VK_WHOLE_SIZE);
    void bind_acceleration_structure(uint32_t binding, ::vk::AccelerationStructureKHR as);
    void bind_texel_buffer(uint32_t binding, ::vk::BufferView view);

    // Drivers may compile lazily, at the first dispatch (lavapipe does): an
    // empty dispatch (0 workgroups; valid Vulkan, does nothing) makes them
    // compile now. Call it once every descriptor is bound; its time is added
    // to the context's pipeline-creation time, not to a render's.
    void warm_up() const;

    // Records bind + push + dispatch into cmd.
    void record(::vk::CommandBuffer cmd, uint32_t gx, uint32_t gy, uint32_t gz, const void* push = nullptr,
                uint32_t push_bytes = 0) const;

private:
    ::vk::DescriptorType type_of(uint32_t binding) const;
    // Writes one descriptor of `binding` (w's set, binding, count and type are filled in).
    void write(uint32_t binding, ::vk::WriteDescriptorSet w);
    const Context& ctx_;
    std::vector<BindingDesc> bindings_;
    std::shared_ptr<const PipelineCore> core_;
    std::unique_ptr<::vk::raii::DescriptorPool> pool_;
    std::unique_ptr<::vk::raii::DescriptorSet> set_;
    uint32_t push_bytes_ = 0;
};

}  // namespace vkmech::vk
