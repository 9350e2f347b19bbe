#include "vk/pipeline.hpp"

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <string>

namespace vkmech::vk {

namespace {

// The inputs that determine a compiled pipeline: the SPIR-V's contents (a 64-bit FNV-1a hash and the size:
// hashing a module takes well under a millisecond, creating its pipeline about a second on lavapipe), the
// bindings, the push-constant size and the specialization.
std::string pipeline_key(std::span<const uint32_t> spirv, const std::vector<BindingDesc>& bindings, uint32_t push_bytes,
                         const std::vector<SpecConstant>& spec) {
    uint64_t h = 14695981039346656037ull;
    for (uint32_t word : spirv) h = (h ^ word) * 1099511628211ull;
    std::string key = std::to_string(h) + ":" + std::to_string(spirv.size()) + "|" + std::to_string(push_bytes) + "|";
    for (const auto& b : bindings)
        key += std::to_string(b.binding) + "=" + std::to_string(static_cast<uint32_t>(b.type)) + ",";
    key += "|";
    for (const auto& c : spec) key += std::to_string(c.id) + "=" + std::to_string(c.value) + ",";
    return key;
}

std::shared_ptr<const PipelineCore> make_core(const Context& ctx, std::span<const uint32_t> spirv,
                                              const std::vector<BindingDesc>& bindings, uint32_t push_bytes,
                                              const std::vector<SpecConstant>& spec) {
    const auto& dev = ctx.device();
    auto core = std::make_shared<PipelineCore>();
    std::vector<::vk::DescriptorSetLayoutBinding> lb;
    for (const auto& b : bindings)
        lb.push_back(::vk::DescriptorSetLayoutBinding{.binding = b.binding,
                                                      .descriptorType = b.type,
                                                      .descriptorCount = 1,
                                                      .stageFlags = ::vk::ShaderStageFlagBits::eCompute});
    core->set_layout = std::make_unique<::vk::raii::DescriptorSetLayout>(
        dev,
        ::vk::DescriptorSetLayoutCreateInfo{.bindingCount = static_cast<uint32_t>(lb.size()), .pBindings = lb.data()});
    ::vk::PushConstantRange range{.stageFlags = ::vk::ShaderStageFlagBits::eCompute, .offset = 0, .size = push_bytes};
    ::vk::DescriptorSetLayout raw_layout = **core->set_layout;
    core->layout = std::make_unique<::vk::raii::PipelineLayout>(
        dev, ::vk::PipelineLayoutCreateInfo{.setLayoutCount = 1,
                                            .pSetLayouts = &raw_layout,
                                            .pushConstantRangeCount = push_bytes ? 1u : 0u,
                                            .pPushConstantRanges = push_bytes ? &range : nullptr});
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
        .layout = **core->layout};
    core->pipeline = std::make_unique<::vk::raii::Pipeline>(ctx.create_compute_pipeline(pci));
    return core;
}

}  // namespace

ComputePipeline::ComputePipeline(const Context& ctx, std::span<const uint32_t> spirv, std::vector<BindingDesc> bindings,
                                 uint32_t push_constant_bytes, const std::vector<SpecConstant>& spec)
    : ctx_(ctx), bindings_(std::move(bindings)), push_bytes_(push_constant_bytes) {
    const auto& dev = ctx.device();
    const std::string key = pipeline_key(spirv, bindings_, push_bytes_, spec);
    core_ = ctx.kept_pipeline(key);
    if (core_) {
        ctx.pipeline_cache().record_reuse();  // nothing created, nothing compiled
    } else {
        core_ = make_core(ctx, spirv, bindings_, push_bytes_, spec);
        ctx.keep_pipeline(key, core_);
    }
    std::map<::vk::DescriptorType, uint32_t> counts;
    for (const auto& b : bindings_) counts[b.type] += 1;
    ::vk::DescriptorSetLayout raw_layout = **core_->set_layout;

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
    cmd.bindPipeline(::vk::PipelineBindPoint::eCompute, **core_->pipeline);
    cmd.bindDescriptorSets(::vk::PipelineBindPoint::eCompute, **core_->layout, 0, {**set_}, {});
    if (push && push_bytes)
        cmd.pushConstants(**core_->layout, ::vk::ShaderStageFlagBits::eCompute, 0, push_bytes, push);
    cmd.dispatch(gx, gy, gz);
}

}  // namespace vkmech::vk
