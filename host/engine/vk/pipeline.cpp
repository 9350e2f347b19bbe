#include "vk/pipeline.hpp"

#include <chrono>
#include <map>

namespace vkmech::vk {

ComputePipeline::ComputePipeline(const Context& ctx, std::span<const uint32_t> spirv, std::vector<BindingDesc> bindings,
                                 uint32_t push_constant_bytes, const std::vector<SpecConstant>& spec)
    : ctx_(ctx), bindings_(std::move(bindings)), push_bytes_(push_constant_bytes) {
    const auto& dev = ctx.device();
    std::vector<::vk::DescriptorSetLayoutBinding> lb;
    std::map<::vk::DescriptorType, uint32_t> counts;
    for (const auto& b : bindings_) {
        lb.push_back(::vk::DescriptorSetLayoutBinding{.binding = b.binding,
                                                      .descriptorType = b.type,
                                                      .descriptorCount = 1,
                                                      .stageFlags = ::vk::ShaderStageFlagBits::eCompute});
        counts[b.type] += 1;
    }
    set_layout_ = std::make_unique<::vk::raii::DescriptorSetLayout>(
        dev,
        ::vk::DescriptorSetLayoutCreateInfo{.bindingCount = static_cast<uint32_t>(lb.size()), .pBindings = lb.data()});
    ::vk::PushConstantRange range{.stageFlags = ::vk::ShaderStageFlagBits::eCompute, .offset = 0, .size = push_bytes_};
    ::vk::DescriptorSetLayout raw_layout = **set_layout_;
    layout_ = std::make_unique<::vk::raii::PipelineLayout>(
        dev, ::vk::PipelineLayoutCreateInfo{.setLayoutCount = 1,
                                            .pSetLayouts = &raw_layout,
                                            .pushConstantRangeCount = push_bytes_ ? 1u : 0u,
                                            .pPushConstantRanges = push_bytes_ ? &range : nullptr});
    ::vk::raii::ShaderModule module(
        dev, ::vk::ShaderModuleCreateInfo{.codeSize = spirv.size_bytes(), .pCode = spirv.data()});
    std::vector<::vk::SpecializationMapEntry> entries;
    std::vector<uint32_t> values;
    for (size_t i = 0; i < spec.size(); ++i) {
        entries.push_back(::vk::SpecializationMapEntry{
            .constantID = spec[i].id, .offset = static_cast<uint32_t>(i * sizeof(uint32_t)), .size = sizeof(uint32_t)});
        values.push_back(spec[i].value);
    }
    ::vk::SpecializationInfo spec_info{.mapEntryCount = static_cast<uint32_t>(entries.size()),
                                       .pMapEntries = entries.data(),
                                       .dataSize = values.size() * sizeof(uint32_t),
                                       .pData = values.data()};
    ::vk::ComputePipelineCreateInfo pci{
        .stage = ::vk::PipelineShaderStageCreateInfo{.stage = ::vk::ShaderStageFlagBits::eCompute,
                                                     .module = *module,
                                                     .pName = "main",
                                                     .pSpecializationInfo = spec.empty() ? nullptr : &spec_info},
        .layout = **layout_};
    pipeline_ = std::make_unique<::vk::raii::Pipeline>(ctx.create_compute_pipeline(pci));

    std::vector<::vk::DescriptorPoolSize> sizes;
    for (auto [type, n] : counts) sizes.push_back(::vk::DescriptorPoolSize{.type = type, .descriptorCount = n});
    pool_ = std::make_unique<::vk::raii::DescriptorPool>(
        dev, ::vk::DescriptorPoolCreateInfo{.flags = ::vk::DescriptorPoolCreateFlagBits::eFreeDescriptorSet,
                                            .maxSets = 1,
                                            .poolSizeCount = static_cast<uint32_t>(sizes.size()),
                                            .pPoolSizes = sizes.data()});
    ::vk::raii::DescriptorSets sets(
        dev, ::vk::DescriptorSetAllocateInfo{
                 .descriptorPool = **pool_, .descriptorSetCount = 1, .pSetLayouts = &raw_layout});
    set_ = std::make_unique<::vk::raii::DescriptorSet>(std::move(sets[0]));
}

::vk::DescriptorType ComputePipeline::type_of(uint32_t binding) const {
    for (const auto& b : bindings_)
        if (b.binding == binding) return b.type;
    throw VulkanError("ComputePipeline: binding " + std::to_string(binding) + " is not in the layout");
}

void ComputePipeline::write(uint32_t binding, ::vk::WriteDescriptorSet w) {
    w.dstSet = **set_;
    w.dstBinding = binding;
    w.descriptorCount = 1;
    w.descriptorType = type_of(binding);
    ctx_.device().updateDescriptorSets(w, nullptr);
}

void ComputePipeline::bind_buffer(uint32_t binding, ::vk::Buffer buffer, ::vk::DeviceSize size) {
    ::vk::DescriptorBufferInfo info{.buffer = buffer, .offset = 0, .range = size};
    write(binding, ::vk::WriteDescriptorSet{.pBufferInfo = &info});
}

void ComputePipeline::bind_acceleration_structure(uint32_t binding, ::vk::AccelerationStructureKHR as) {
    ::vk::WriteDescriptorSetAccelerationStructureKHR as_info{.accelerationStructureCount = 1,
                                                             .pAccelerationStructures = &as};
    write(binding, ::vk::WriteDescriptorSet{.pNext = &as_info});
}

void ComputePipeline::bind_texel_buffer(uint32_t binding, ::vk::BufferView view) {
    write(binding, ::vk::WriteDescriptorSet{.pTexelBufferView = &view});
}

void ComputePipeline::warm_up() const {
    auto t0 = std::chrono::steady_clock::now();
    std::vector<uint8_t> zeros(push_bytes_, 0);
    ctx_.submit_and_wait([&](::vk::CommandBuffer cmd) { record(cmd, 0, 0, 0, zeros.data(), push_bytes_); });
    ctx_.pipeline_cache().add_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
}

void ComputePipeline::record(::vk::CommandBuffer cmd, uint32_t gx, uint32_t gy, uint32_t gz, const void* push,
                             uint32_t push_bytes) const {
    cmd.bindPipeline(::vk::PipelineBindPoint::eCompute, **pipeline_);
    cmd.bindDescriptorSets(::vk::PipelineBindPoint::eCompute, **layout_, 0, {**set_}, {});
    if (push && push_bytes) cmd.pushConstants(**layout_, ::vk::ShaderStageFlagBits::eCompute, 0, push_bytes, push);
    cmd.dispatch(gx, gy, gz);
}

}  // namespace vkmech::vk
