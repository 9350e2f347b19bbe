#include "vk/context.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>

namespace vkmech::vk {

void check(::vk::Result r, const char* call) {
    if (r != ::vk::Result::eSuccess) throw VulkanError(std::string(call) + " failed: " + ::vk::to_string(r));
}
void check(VkResult r, const char* call) { check(static_cast<::vk::Result>(r), call); }

const char* to_string(KernelClass k) {
    switch (k) {
        case KernelClass::Cpu:
            return "cpu";
        case KernelClass::Gpu:
            return "gpu";
        default:
            return "auto";
    }
}

KernelClass parse_kernel_class(const std::string& s) {
    if (s == "auto") return KernelClass::Auto;
    if (s == "cpu") return KernelClass::Cpu;
    if (s == "gpu") return KernelClass::Gpu;
    throw std::invalid_argument("kernel '" + s + "': expected auto, cpu or gpu");
}

struct Context::Messages : MessageTally {};

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

const char* device_type_name(::vk::PhysicalDeviceType t) {
    switch (t) {
        case ::vk::PhysicalDeviceType::eDiscreteGpu:
            return "discrete";
        case ::vk::PhysicalDeviceType::eIntegratedGpu:
            return "integrated";
        case ::vk::PhysicalDeviceType::eVirtualGpu:
            return "virtual";
        case ::vk::PhysicalDeviceType::eCpu:
            return "cpu";
        default:
            return "other";
    }
}

int type_rank(::vk::PhysicalDeviceType t) {
    switch (t) {
        case ::vk::PhysicalDeviceType::eDiscreteGpu:
            return 0;
        case ::vk::PhysicalDeviceType::eIntegratedGpu:
            return 1;
        case ::vk::PhysicalDeviceType::eVirtualGpu:
            return 2;
        case ::vk::PhysicalDeviceType::eCpu:
            return 3;
        default:
            return 4;
    }
}

bool has_extension(const std::vector<::vk::ExtensionProperties>& exts, const char* name) {
    return std::any_of(exts.begin(), exts.end(),
                       [&](const ::vk::ExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
}

DeviceInfo describe(const ::vk::raii::PhysicalDevice& pd, uint32_t index) {
    DeviceInfo info;
    info.index = index;
    auto props = pd.getProperties();
    info.name = props.deviceName.data();
    info.type = device_type_name(props.deviceType);
    info.api_version = props.apiVersion;
    info.max_workgroup_invocations = props.limits.maxComputeWorkGroupInvocations;
    info.max_storage_buffer_range = props.limits.maxStorageBufferRange;
    auto exts = pd.enumerateDeviceExtensionProperties();
    bool rq = has_extension(exts, VK_KHR_RAY_QUERY_EXTENSION_NAME) &&
              has_extension(exts, VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME) &&
              has_extension(exts, VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME);
    if (rq) {
        auto chain = pd.getFeatures2<::vk::PhysicalDeviceFeatures2, ::vk::PhysicalDeviceRayQueryFeaturesKHR,
                                     ::vk::PhysicalDeviceAccelerationStructureFeaturesKHR>();
        rq = chain.get<::vk::PhysicalDeviceRayQueryFeaturesKHR>().rayQuery &&
             chain.get<::vk::PhysicalDeviceAccelerationStructureFeaturesKHR>().accelerationStructure;
    }
    info.ray_query = rq;
    if (props.apiVersion >= VK_API_VERSION_1_2) {
        auto chain = pd.getProperties2<::vk::PhysicalDeviceProperties2, ::vk::PhysicalDeviceDriverProperties,
                                       ::vk::PhysicalDeviceSubgroupProperties>();
        const auto& drv = chain.get<::vk::PhysicalDeviceDriverProperties>();
        info.driver = std::string(drv.driverName.data()) + " " + drv.driverInfo.data();
        const auto& sg = chain.get<::vk::PhysicalDeviceSubgroupProperties>();
        info.compute_subgroup_ballot = (sg.supportedStages & ::vk::ShaderStageFlagBits::eCompute) &&
                                       (sg.supportedOperations & ::vk::SubgroupFeatureFlagBits::eBallot);
    }
    auto mem = pd.getMemoryProperties();
    for (uint32_t i = 0; i < mem.memoryHeapCount; ++i)
        if (mem.memoryHeaps[i].flags & ::vk::MemoryHeapFlagBits::eDeviceLocal)
            info.device_local_bytes = std::max<uint64_t>(info.device_local_bytes, mem.memoryHeaps[i].size);
    return info;
}

VKAPI_ATTR VkBool32 VKAPI_CALL debug_callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                              VkDebugUtilsMessageTypeFlagsEXT,
                                              const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
    if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
        auto* tally = static_cast<MessageTally*>(user);
        if (tally->expecting.load() > 0) {
            std::fprintf(stderr, "vkmech: validation (expected, not counted): %s\n", data->pMessage);
            return VK_FALSE;
        }
        tally->count.fetch_add(1);
        std::fprintf(stderr, "vkmech: validation: %s\n", data->pMessage);
    }
    return VK_FALSE;
}

::vk::raii::Instance make_instance(const ::vk::raii::Context& ctx, bool validation, bool* validation_on) {
    ::vk::ApplicationInfo app{.pApplicationName = "vkmech",
                              .applicationVersion = 1,
                              .pEngineName = "vkmech",
                              .engineVersion = 1,
                              .apiVersion = VK_API_VERSION_1_2};
    std::vector<const char*> layers;
    std::vector<const char*> extensions;
    *validation_on = false;
    if (validation) {
        auto props = ctx.enumerateInstanceLayerProperties();
        bool found = std::any_of(props.begin(), props.end(), [](const ::vk::LayerProperties& l) {
            return std::strcmp(l.layerName, kValidationLayer) == 0;
        });
        if (found) {
            layers.push_back(kValidationLayer);
            extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
            *validation_on = true;
        }
    }
    ::vk::InstanceCreateInfo ci{.pApplicationInfo = &app,
                                .enabledLayerCount = static_cast<uint32_t>(layers.size()),
                                .ppEnabledLayerNames = layers.data(),
                                .enabledExtensionCount = static_cast<uint32_t>(extensions.size()),
                                .ppEnabledExtensionNames = extensions.data()};
    try {
        return ::vk::raii::Instance(ctx, ci);
    } catch (const ::vk::SystemError& e) {
        throw VulkanError(std::string("vkCreateInstance failed: ") + e.what() +
                          " (is a Vulkan driver installed? run ci/install-deps.sh for Mesa lavapipe)");
    }
}

}  // namespace

std::vector<DeviceInfo> Context::list_devices() {
    ::vk::raii::Context ctx;
    bool v = false;
    ::vk::raii::Instance instance = make_instance(ctx, false, &v);
    ::vk::raii::PhysicalDevices devices(instance);
    std::vector<DeviceInfo> out;
    for (uint32_t i = 0; i < devices.size(); ++i) out.push_back(describe(devices[i], i));
    return out;
}

Context::Context(const ContextOptions& options) : messages_(std::make_unique<Messages>()) {
    instance_ =
        std::make_unique<::vk::raii::Instance>(make_instance(context_, options.validation, &validation_enabled_));
    if (validation_enabled_) {
        ::vk::DebugUtilsMessengerCreateInfoEXT mci{
            .messageSeverity = ::vk::DebugUtilsMessageSeverityFlagBitsEXT::eWarning |
                               ::vk::DebugUtilsMessageSeverityFlagBitsEXT::eError,
            .messageType = ::vk::DebugUtilsMessageTypeFlagBitsEXT::eGeneral |
                           ::vk::DebugUtilsMessageTypeFlagBitsEXT::eValidation |
                           ::vk::DebugUtilsMessageTypeFlagBitsEXT::ePerformance,
            .pfnUserCallback = debug_callback,
            .pUserData = static_cast<MessageTally*>(messages_.get())};
        messenger_ = std::make_unique<::vk::raii::DebugUtilsMessengerEXT>(*instance_, mci);
    }

    ::vk::raii::PhysicalDevices devices(*instance_);
    if (devices.empty()) throw VulkanError("no Vulkan device found (install Mesa lavapipe: ci/install-deps.sh)");
    uint32_t chosen = 0;
    if (options.device_index) {
        if (*options.device_index >= devices.size())
            throw VulkanError("--device " + std::to_string(*options.device_index) + ": only " +
                              std::to_string(devices.size()) + " device(s) present (see `vkmech devices`)");
        chosen = *options.device_index;
    } else {
        // Prefer a discrete GPU, then integrated, virtual, CPU (lavapipe).
        int best = 1 << 30;
        for (uint32_t i = 0; i < devices.size(); ++i) {
            auto props = devices[i].getProperties();
            if (props.apiVersion < VK_API_VERSION_1_2) continue;
            int rank = type_rank(props.deviceType);
            if (rank < best) {
                best = rank;
                chosen = i;
            }
        }
    }
    physical_ = std::make_unique<::vk::raii::PhysicalDevice>(std::move(devices[chosen]));
    info_ = describe(*physical_, chosen);
    kernel_ = options.kernel;
    if (kernel_ == KernelClass::Auto) {
        const char* env = std::getenv("VKMECH_KERNEL");
        if (env && *env) {
            try {
                kernel_ = parse_kernel_class(env);
            } catch (const std::invalid_argument& e) {
                throw std::invalid_argument(std::string("VKMECH_KERNEL: ") + e.what());
            }
        }
    }
    if (kernel_ == KernelClass::Auto) {
        // The GPU kernel reads every scene array as a storage buffer: 14 of them in one
        // stage. A device that allows fewer (Vulkan guarantees 4) runs the CPU kernel,
        // whose arrays are texel buffers (sampled-image limit, at least 16).
        const auto& limits = physical_->getProperties().limits;
        kernel_ = info_.type != "cpu" && limits.maxPerStageDescriptorStorageBuffers >= 16 ? KernelClass::Gpu
                                                                                          : KernelClass::Cpu;
    }
    if (info_.api_version < VK_API_VERSION_1_2)
        throw VulkanError("device '" + info_.name + "' supports only Vulkan " +
                          std::to_string(VK_API_VERSION_MAJOR(info_.api_version)) + "." +
                          std::to_string(VK_API_VERSION_MINOR(info_.api_version)) + "; vkmech needs 1.2");

    auto families = physical_->getQueueFamilyProperties();
    bool found = false;
    for (uint32_t i = 0; i < families.size(); ++i) {
        if (families[i].queueFlags & ::vk::QueueFlagBits::eCompute) {
            queue_family_ = i;
            found = true;
            break;
        }
    }
    if (!found) throw VulkanError("device '" + info_.name + "' has no compute queue");

    ray_query_enabled_ = options.want_ray_query && info_.ray_query;
    std::vector<const char*> exts;
    if (ray_query_enabled_) {
        exts = {VK_KHR_RAY_QUERY_EXTENSION_NAME, VK_KHR_ACCELERATION_STRUCTURE_EXTENSION_NAME,
                VK_KHR_DEFERRED_HOST_OPERATIONS_EXTENSION_NAME};
    }
    // Creation feedback says whether a pipeline came from the cache (core in
    // Vulkan 1.3; an extension on 1.2 devices).
    {
        auto available = physical_->enumerateDeviceExtensionProperties();
        creation_feedback_ = has_extension(available, VK_EXT_PIPELINE_CREATION_FEEDBACK_EXTENSION_NAME);
        if (creation_feedback_) exts.push_back(VK_EXT_PIPELINE_CREATION_FEEDBACK_EXTENSION_NAME);
        if (has_extension(available, VK_KHR_SHADER_CLOCK_EXTENSION_NAME)) {
            auto chain =
                physical_->getFeatures2<::vk::PhysicalDeviceFeatures2, ::vk::PhysicalDeviceShaderClockFeaturesKHR>();
            shader_clock_enabled_ = chain.get<::vk::PhysicalDeviceShaderClockFeaturesKHR>().shaderSubgroupClock;
            if (shader_clock_enabled_) exts.push_back(VK_KHR_SHADER_CLOCK_EXTENSION_NAME);
        }
    }
    float priority = 1.0f;
    ::vk::DeviceQueueCreateInfo qci{.queueFamilyIndex = queue_family_, .queueCount = 1, .pQueuePriorities = &priority};

    auto supported = physical_->getFeatures2<::vk::PhysicalDeviceFeatures2, ::vk::PhysicalDeviceVulkan12Features>();
    const auto& sup12 = supported.get<::vk::PhysicalDeviceVulkan12Features>();
    ::vk::PhysicalDeviceRayQueryFeaturesKHR rq_features{.rayQuery = VK_TRUE};
    ::vk::PhysicalDeviceAccelerationStructureFeaturesKHR as_features{.pNext = &rq_features,
                                                                     .accelerationStructure = VK_TRUE};
    ::vk::PhysicalDeviceVulkan12Features f12{.pNext = ray_query_enabled_ ? &as_features : nullptr,
                                             .bufferDeviceAddress = ray_query_enabled_ ? VK_TRUE : VK_FALSE};
    (void)sup12;
    ::vk::PhysicalDeviceShaderClockFeaturesKHR clock_features{.pNext = &f12, .shaderSubgroupClock = VK_TRUE};
    ::vk::PhysicalDeviceFeatures2 f2{.pNext = shader_clock_enabled_ ? static_cast<void*>(&clock_features) : &f12};
    ::vk::DeviceCreateInfo dci{.pNext = &f2,
                               .queueCreateInfoCount = 1,
                               .pQueueCreateInfos = &qci,
                               .enabledExtensionCount = static_cast<uint32_t>(exts.size()),
                               .ppEnabledExtensionNames = exts.data()};
    try {
        device_ = std::make_unique<::vk::raii::Device>(*physical_, dci);
    } catch (const ::vk::SystemError& e) {
        throw VulkanError(std::string("vkCreateDevice failed: ") + e.what());
    }
    queue_ = std::make_unique<::vk::raii::Queue>(*device_, queue_family_, 0);
    pool_ = std::make_unique<::vk::raii::CommandPool>(
        *device_, ::vk::CommandPoolCreateInfo{.flags = ::vk::CommandPoolCreateFlagBits::eResetCommandBuffer,
                                              .queueFamilyIndex = queue_family_});
    fence_ = std::make_unique<::vk::raii::Fence>(*device_, ::vk::FenceCreateInfo{});
    std::string cache_dir = options.pipeline_cache_dir.value_or(default_pipeline_cache_dir());
    if (cache_dir == "off") cache_dir.clear();
    pipeline_cache_ = std::make_unique<PipelineCache>(*device_, *physical_, cache_dir, messages_.get());
}

::vk::raii::Pipeline Context::create_compute_pipeline(const ::vk::ComputePipelineCreateInfo& info) const {
    ::vk::ComputePipelineCreateInfo ci = info;
    ::vk::PipelineCreationFeedback whole{};
    ::vk::PipelineCreationFeedbackCreateInfo feedback{.pPipelineCreationFeedback = &whole};
    if (creation_feedback_) {
        feedback.pNext = ci.pNext;
        ci.pNext = &feedback;
    }
    auto t0 = std::chrono::steady_clock::now();
    ::vk::raii::Pipeline pipeline(*device_, ::vk::Optional<const ::vk::raii::PipelineCache>(pipeline_cache_->raii()),
                                  ci);
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    bool hit = (whole.flags & ::vk::PipelineCreationFeedbackFlagBits::eValid) &&
               (whole.flags & ::vk::PipelineCreationFeedbackFlagBits::eApplicationPipelineCacheHit);
    pipeline_cache_->record(seconds, hit);
    pipeline_cache_->save();
    return pipeline;
}

std::shared_ptr<const PipelineCore> Context::kept_pipeline(const std::string& key) const {
    std::lock_guard<std::mutex> lock(kept_mutex_);
    for (auto it = kept_.begin(); it != kept_.end(); ++it)
        if (it->first == key) {
            kept_.splice(kept_.begin(), kept_, it);  // the most recently used first
            return kept_.front().second;
        }
    return nullptr;
}

void Context::keep_pipeline(const std::string& key, std::shared_ptr<const PipelineCore> core) const {
    std::lock_guard<std::mutex> lock(kept_mutex_);
    kept_.emplace_front(key, std::move(core));
    if (kept_.size() > kKeptPipelines) kept_.pop_back();
}

Context::~Context() {
    if (device_) device_->waitIdle();
    kept_.clear();  // before the device and the validation messenger's messages
}

uint32_t Context::validation_messages() const { return messages_->count.load(); }

uint32_t Context::find_memory_type(uint32_t type_bits, ::vk::MemoryPropertyFlags wanted,
                                   ::vk::MemoryPropertyFlags fallback) const {
    auto mem = physical_->getMemoryProperties();
    for (auto flags : {wanted, fallback}) {
        for (uint32_t i = 0; i < mem.memoryTypeCount; ++i)
            if ((type_bits & (1u << i)) && (mem.memoryTypes[i].propertyFlags & flags) == flags) return i;
        if (!fallback) break;
    }
    throw VulkanError("no Vulkan memory type with the requested properties");
}

::vk::raii::CommandBuffer Context::begin_one_shot() const {
    ::vk::raii::CommandBuffers cmds(
        *device_, ::vk::CommandBufferAllocateInfo{
                      .commandPool = **pool_, .level = ::vk::CommandBufferLevel::ePrimary, .commandBufferCount = 1});
    ::vk::raii::CommandBuffer cmd = std::move(cmds[0]);
    cmd.begin(::vk::CommandBufferBeginInfo{.flags = ::vk::CommandBufferUsageFlagBits::eOneTimeSubmit});
    // Earlier submissions' writes (a dispatch's results, a copy) become
    // visible to these commands: a barrier's first scope covers every
    // command submitted before it, and a fence alone orders execution only.
    cmd.pipelineBarrier(
        ::vk::PipelineStageFlagBits::eAllCommands, ::vk::PipelineStageFlagBits::eAllCommands, {},
        ::vk::MemoryBarrier{.srcAccessMask = ::vk::AccessFlagBits::eMemoryWrite,
                            .dstAccessMask = ::vk::AccessFlagBits::eMemoryRead | ::vk::AccessFlagBits::eMemoryWrite},
        {}, {});
    return cmd;
}

void Context::end_one_shot(::vk::raii::CommandBuffer& cmd) const {
    // The device's writes become visible to host reads after the fence
    // (Vulkan: a fence's memory dependency covers device accesses only).
    cmd.pipelineBarrier(::vk::PipelineStageFlagBits::eAllCommands, ::vk::PipelineStageFlagBits::eHost, {},
                        ::vk::MemoryBarrier{.srcAccessMask = ::vk::AccessFlagBits::eMemoryWrite,
                                            .dstAccessMask = ::vk::AccessFlagBits::eHostRead},
                        {}, {});
    cmd.end();
    ::vk::CommandBuffer raw = *cmd;
    device_->resetFences({**fence_});
    queue_->submit(::vk::SubmitInfo{.commandBufferCount = 1, .pCommandBuffers = &raw}, **fence_);
    auto r = device_->waitForFences({**fence_}, VK_TRUE, UINT64_MAX);
    check(r, "vkWaitForFences");
}

}  // namespace vkmech::vk
