#include "vk/buffer.hpp"

#include <cstdio>

namespace vkmech::vk {

std::string byte_size_text(uint64_t b) {
    char buf[32];
    if (b >= (1ull << 30))
        std::snprintf(buf, sizeof buf, "%.1f GiB", static_cast<double>(b) / (1ull << 30));
    else if (b >= (1ull << 20))
        std::snprintf(buf, sizeof buf, "%.1f MiB", static_cast<double>(b) / (1ull << 20));
    else if (b >= (1ull << 10))
        std::snprintf(buf, sizeof buf, "%.1f KiB", static_cast<double>(b) / (1ull << 10));
    else
        std::snprintf(buf, sizeof buf, "%llu B", static_cast<unsigned long long>(b));
    return buf;
}

Buffer::Buffer(const Context& ctx, ::vk::DeviceSize size, ::vk::BufferUsageFlags usage, MemoryUse use) : size_(size) {
    try {
        allocate(ctx, usage, use);
    } catch (const ::vk::OutOfDeviceMemoryError&) {
        throw OutOfMemoryError("cannot allocate a buffer of " + byte_size_text(size) + " (out of device memory)", size);
    } catch (const ::vk::OutOfHostMemoryError&) {
        throw OutOfMemoryError("cannot allocate a buffer of " + byte_size_text(size) + " (out of host memory)", size);
    } catch (const std::bad_alloc&) {
        throw OutOfMemoryError("cannot allocate a buffer of " + byte_size_text(size) + " (out of host memory)", size);
    }
}

void Buffer::allocate(const Context& ctx, ::vk::BufferUsageFlags usage, MemoryUse use) {
    const ::vk::DeviceSize size = size_;
    if (use == MemoryUse::Device)
        usage |= ::vk::BufferUsageFlagBits::eTransferDst | ::vk::BufferUsageFlagBits::eTransferSrc;
    buffer_ = std::make_unique<::vk::raii::Buffer>(ctx.device(), ::vk::BufferCreateInfo{.size = size, .usage = usage});
    auto req = buffer_->getMemoryRequirements();
    using MP = ::vk::MemoryPropertyFlagBits;
    uint32_t type = 0;
    switch (use) {
        case MemoryUse::Device:
            type = ctx.find_memory_type(req.memoryTypeBits, MP::eDeviceLocal, {});
            break;
        case MemoryUse::Upload:
            type = ctx.find_memory_type(req.memoryTypeBits, MP::eHostVisible | MP::eHostCoherent, MP::eHostVisible);
            break;
        case MemoryUse::Readback:
            type = ctx.find_memory_type(req.memoryTypeBits, MP::eHostVisible | MP::eHostCached, MP::eHostVisible);
            break;
    }
    auto props = ctx.physical().getMemoryProperties();
    auto flags = props.memoryTypes[type].propertyFlags;
    ::vk::MemoryAllocateFlagsInfo flags_info{.flags = ::vk::MemoryAllocateFlagBits::eDeviceAddress};
    bool wants_address = static_cast<bool>(usage & ::vk::BufferUsageFlagBits::eShaderDeviceAddress);
    ::vk::MemoryDedicatedAllocateInfo dedicated{.pNext = wants_address ? &flags_info : nullptr, .buffer = **buffer_};
    memory_ = std::make_unique<::vk::raii::DeviceMemory>(
        ctx.device(),
        ::vk::MemoryAllocateInfo{.pNext = &dedicated, .allocationSize = req.size, .memoryTypeIndex = type});
    buffer_->bindMemory(**memory_, 0);
    if (flags & MP::eHostVisible) {
        mapped_ = memory_->mapMemory(0, VK_WHOLE_SIZE);
        coherent_ = static_cast<bool>(flags & MP::eHostCoherent);
    }
}

::vk::DeviceAddress Buffer::address(const Context& ctx) const {
    return ctx.device().getBufferAddress(::vk::BufferDeviceAddressInfo{.buffer = **buffer_});
}

void Buffer::upload(const Context& ctx, const void* data, ::vk::DeviceSize bytes, ::vk::DeviceSize offset) {
    if (bytes == 0) return;
    if (offset + bytes > size_) throw VulkanError("Buffer::upload: write past the end of the buffer");
    if (mapped_) {
        std::memcpy(static_cast<char*>(mapped_) + offset, data, bytes);
        if (!coherent_)
            ctx.device().flushMappedMemoryRanges(
                ::vk::MappedMemoryRange{.memory = **memory_, .offset = 0, .size = VK_WHOLE_SIZE});
        return;
    }
    Buffer staging(ctx, bytes, ::vk::BufferUsageFlagBits::eTransferSrc, MemoryUse::Upload);
    staging.upload(ctx, data, bytes);
    ctx.submit_and_wait([&](::vk::CommandBuffer cmd) {
        cmd.copyBuffer(staging.handle(), handle(),
                       ::vk::BufferCopy{.srcOffset = 0, .dstOffset = offset, .size = bytes});
    });
}

void Buffer::download(const Context& ctx, void* data, ::vk::DeviceSize bytes, ::vk::DeviceSize offset) const {
    if (bytes == 0) return;
    if (offset + bytes > size_) throw VulkanError("Buffer::download: read past the end of the buffer");
    if (mapped_) {
        if (!coherent_)
            ctx.device().invalidateMappedMemoryRanges(
                ::vk::MappedMemoryRange{.memory = **memory_, .offset = 0, .size = VK_WHOLE_SIZE});
        std::memcpy(data, static_cast<const char*>(mapped_) + offset, bytes);
        return;
    }
    Buffer staging(ctx, bytes, ::vk::BufferUsageFlagBits::eTransferDst, MemoryUse::Readback);
    ctx.submit_and_wait([&](::vk::CommandBuffer cmd) {
        cmd.copyBuffer(handle(), staging.handle(),
                       ::vk::BufferCopy{.srcOffset = offset, .dstOffset = 0, .size = bytes});
    });
    staging.download(ctx, data, bytes);
}

}  // namespace vkmech::vk
