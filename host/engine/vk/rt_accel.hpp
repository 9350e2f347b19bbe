// BLAS/TLAS for VK_KHR_ray_query: one BLAS over the scene arrays' triangles
// in their order (the scene's own unless the arrays were built for the
// software BVH), so gl_PrimitiveID indexes the scene arrays; with instancing,
// a BLAS per shape group besides, instanced in the TLAS.
#pragma once

#include "shared/types.h"
#include "vk/buffer.hpp"

#include <glm/glm.hpp>

#include <memory>
#include <vector>

namespace vkmech {

class RayTracingAccel {
public:
    // positions: 3 vec4 per triangle (xyz used), already on the device with
    // eAccelerationStructureBuildInputReadOnlyKHR | eShaderDeviceAddress usage.
    RayTracingAccel(const vk::Context& ctx, const vk::Buffer& positions, uint32_t triangle_count);
    // With instancing (SceneArrays::group_triangles, instances): a BLAS over the ordinary
    // triangles [0, first group's first) as one identity instance (custom index 0xFFFFFF), a
    // BLAS per shape group over its range, and per instance its group's BLAS under its
    // to_world (custom index: the instance). A group's primitive i is triangle
    // GpuInstance.info.z + i. At most 2^24 - 2 instances (VulkanError).
    RayTracingAccel(const vk::Context& ctx, const vk::Buffer& positions, uint32_t triangle_count,
                    const std::vector<glm::uvec2>& group_triangles, const std::vector<gpu::GpuInstance>& instances);
    ::vk::AccelerationStructureKHR tlas() const { return **tlas_; }
    double build_seconds() const { return build_seconds_; }

private:
    std::vector<vk::Buffer> blas_buffers_;
    vk::Buffer tlas_buffer_, instances_;
    std::vector<std::unique_ptr<::vk::raii::AccelerationStructureKHR>> blas_;
    std::unique_ptr<::vk::raii::AccelerationStructureKHR> tlas_;
    double build_seconds_ = 0.0;
};

}  // namespace vkmech
