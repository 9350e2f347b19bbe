// A buffer with its own dedicated allocation (no VMA package in Debian; a
// dedicated allocation per buffer is plenty for a handful of scene buffers).
#pragma once

#include "vk/context.hpp"

#include <cstring>
#include <vector>

namespace vkmech::vk {

// An allocation the device or the host cannot satisfy (docs/reliability.md): says how
// much was asked; callers that know what it was for add that and what to lower.
class OutOfMemoryError : public VulkanError {
public:
    OutOfMemoryError(const std::string& what, uint64_t bytes) : VulkanError(what), bytes_(bytes) {}
    uint64_t bytes() const { return bytes_; }

private:
    uint64_t bytes_;
};

// "6.4 GiB", "512 MiB", "12 KiB", "80 B".
std::string byte_size_text(uint64_t bytes);

enum class MemoryUse {
    Device,    // device-local; filled through a staging copy
    Upload,    // host-visible, written by the CPU
    Readback,  // host-visible and cached, read by the CPU
};

class Buffer {
public:
    Buffer() = default;
    Buffer(const Context& ctx, ::vk::DeviceSize size, ::vk::BufferUsageFlags usage, MemoryUse use);

    ::vk::Buffer handle() const { return buffer_ ? **buffer_ : ::vk::Buffer{}; }
    ::vk::DeviceSize size() const { return size_; }
    bool host_visible() const { return mapped_ != nullptr; }
    ::vk::DeviceAddress address(const Context& ctx) const;

    // Host-visible buffers: direct; device-local: through a staging buffer.
    void upload(const Context& ctx, const void* data, ::vk::DeviceSize bytes, ::vk::DeviceSize offset = 0);
    void download(const Context& ctx, void* data, ::vk::DeviceSize bytes, ::vk::DeviceSize offset = 0) const;

    template <class T>
    static Buffer from_vector(const Context& ctx, const std::vector<T>& v, ::vk::BufferUsageFlags usage) {
        // Never zero-sized: Vulkan forbids it, and empty scene arrays (no
        // lights) still need a valid descriptor.
        ::vk::DeviceSize bytes = std::max<::vk::DeviceSize>(v.size() * sizeof(T), 16);
        Buffer b(ctx, bytes, usage | ::vk::BufferUsageFlagBits::eTransferDst, MemoryUse::Device);
        if (!v.empty()) b.upload(ctx, v.data(), v.size() * sizeof(T));
        return b;
    }

private:
    void allocate(const Context& ctx, ::vk::BufferUsageFlags usage, MemoryUse use);

    std::unique_ptr<::vk::raii::Buffer> buffer_;
    std::unique_ptr<::vk::raii::DeviceMemory> memory_;
    ::vk::DeviceSize size_ = 0;
    void* mapped_ = nullptr;
    bool coherent_ = true;
};

}  // namespace vkmech::vk
