// BLAS/TLAS for VK_KHR_ray_query: one BLAS over the scene arrays' triangles
// in their order (the scene's own unless the arrays were built for the
// software BVH), so gl_PrimitiveID indexes the scene arrays.
#pragma once

#include "vk/buffer.hpp"

namespace vkmech {

class RayTracingAccel {
public:
    // positions: 3 vec4 per triangle (xyz used), already on the device with
    // eAccelerationStructureBuildInputReadOnlyKHR | eShaderDeviceAddress usage.
    RayTracingAccel(const vk::Context& ctx, const vk::Buffer& positions, uint32_t triangle_count);
    ::vk::AccelerationStructureKHR tlas() const { return **tlas_; }
    double build_seconds() const { return build_seconds_; }

private:
    vk::Buffer blas_buffer_, tlas_buffer_, instances_;
    std::unique_ptr<::vk::raii::AccelerationStructureKHR> blas_, tlas_;
    double build_seconds_ = 0.0;
};

}  // namespace vkmech
