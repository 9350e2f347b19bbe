#include "vk/rt_accel.hpp"

#include <chrono>

namespace vkmech {

namespace {
using BU = ::vk::BufferUsageFlagBits;

::vk::DeviceSize align_up(::vk::DeviceSize v, ::vk::DeviceSize a) { return (v + a - 1) / a * a; }
}  // namespace

RayTracingAccel::RayTracingAccel(const vk::Context& ctx, const vk::Buffer& positions, uint32_t triangle_count) {
    if (!ctx.ray_query_enabled())
        throw vk::VulkanError("ray-query acceleration requested on a device without VK_KHR_ray_query");
    auto t0 = std::chrono::steady_clock::now();
    const auto& dev = ctx.device();
    auto as_props =
        ctx.physical()
            .getProperties2<::vk::PhysicalDeviceProperties2, ::vk::PhysicalDeviceAccelerationStructurePropertiesKHR>()
            .get<::vk::PhysicalDeviceAccelerationStructurePropertiesKHR>();
    const ::vk::DeviceSize scratch_align =
        std::max<::vk::DeviceSize>(as_props.minAccelerationStructureScratchOffsetAlignment, 16);

    // ---- BLAS ----
    ::vk::AccelerationStructureGeometryTrianglesDataKHR tri{
        .vertexFormat = ::vk::Format::eR32G32B32Sfloat,
        .vertexData = ::vk::DeviceOrHostAddressConstKHR{.deviceAddress = positions.address(ctx)},
        .vertexStride = sizeof(float) * 4,
        .maxVertex = triangle_count * 3 - 1,
        .indexType = ::vk::IndexType::eNoneKHR};
    ::vk::AccelerationStructureGeometryKHR geom{
        .geometryType = ::vk::GeometryTypeKHR::eTriangles,
        .geometry = ::vk::AccelerationStructureGeometryDataKHR{.triangles = tri},
        .flags = ::vk::GeometryFlagBitsKHR::eOpaque};
    ::vk::AccelerationStructureBuildGeometryInfoKHR blas_info{
        .type = ::vk::AccelerationStructureTypeKHR::eBottomLevel,
        .flags = ::vk::BuildAccelerationStructureFlagBitsKHR::ePreferFastTrace,
        .mode = ::vk::BuildAccelerationStructureModeKHR::eBuild,
        .geometryCount = 1,
        .pGeometries = &geom};
    auto blas_sizes = dev.getAccelerationStructureBuildSizesKHR(::vk::AccelerationStructureBuildTypeKHR::eDevice,
                                                                blas_info, {triangle_count});
    blas_buffer_ = vk::Buffer(ctx, blas_sizes.accelerationStructureSize,
                              BU::eAccelerationStructureStorageKHR | BU::eShaderDeviceAddress, vk::MemoryUse::Device);
    blas_ = std::make_unique<::vk::raii::AccelerationStructureKHR>(
        dev, ::vk::AccelerationStructureCreateInfoKHR{.buffer = blas_buffer_.handle(),
                                                      .size = blas_sizes.accelerationStructureSize,
                                                      .type = ::vk::AccelerationStructureTypeKHR::eBottomLevel});

    // ---- TLAS: one instance, identity transform ----
    ::vk::AccelerationStructureInstanceKHR inst{};
    inst.transform.matrix[0][0] = inst.transform.matrix[1][1] = inst.transform.matrix[2][2] = 1.0f;
    inst.instanceCustomIndex = 0;
    inst.mask = 0xFF;
    inst.flags = static_cast<VkGeometryInstanceFlagsKHR>(::vk::GeometryInstanceFlagBitsKHR::eTriangleFacingCullDisable);
    inst.accelerationStructureReference = dev.getAccelerationStructureAddressKHR(
        ::vk::AccelerationStructureDeviceAddressInfoKHR{.accelerationStructure = **blas_});
    instances_ =
        vk::Buffer(ctx, sizeof(inst),
                   BU::eAccelerationStructureBuildInputReadOnlyKHR | BU::eShaderDeviceAddress | BU::eTransferDst,
                   vk::MemoryUse::Device);
    instances_.upload(ctx, &inst, sizeof(inst));
    ::vk::AccelerationStructureGeometryKHR tgeom{
        .geometryType = ::vk::GeometryTypeKHR::eInstances,
        .geometry =
            ::vk::AccelerationStructureGeometryDataKHR{
                .instances =
                    ::vk::AccelerationStructureGeometryInstancesDataKHR{
                        .arrayOfPointers = VK_FALSE,
                        .data = ::vk::DeviceOrHostAddressConstKHR{.deviceAddress = instances_.address(ctx)}}},
        .flags = ::vk::GeometryFlagBitsKHR::eOpaque};
    ::vk::AccelerationStructureBuildGeometryInfoKHR tlas_info{
        .type = ::vk::AccelerationStructureTypeKHR::eTopLevel,
        .flags = ::vk::BuildAccelerationStructureFlagBitsKHR::ePreferFastTrace,
        .mode = ::vk::BuildAccelerationStructureModeKHR::eBuild,
        .geometryCount = 1,
        .pGeometries = &tgeom};
    auto tlas_sizes =
        dev.getAccelerationStructureBuildSizesKHR(::vk::AccelerationStructureBuildTypeKHR::eDevice, tlas_info, {1u});
    tlas_buffer_ = vk::Buffer(ctx, tlas_sizes.accelerationStructureSize,
                              BU::eAccelerationStructureStorageKHR | BU::eShaderDeviceAddress, vk::MemoryUse::Device);
    tlas_ = std::make_unique<::vk::raii::AccelerationStructureKHR>(
        dev, ::vk::AccelerationStructureCreateInfoKHR{.buffer = tlas_buffer_.handle(),
                                                      .size = tlas_sizes.accelerationStructureSize,
                                                      .type = ::vk::AccelerationStructureTypeKHR::eTopLevel});

    ::vk::DeviceSize scratch_size =
        align_up(std::max(blas_sizes.buildScratchSize, tlas_sizes.buildScratchSize), scratch_align) + scratch_align;
    vk::Buffer scratch(ctx, scratch_size, BU::eStorageBuffer | BU::eShaderDeviceAddress, vk::MemoryUse::Device);
    ::vk::DeviceAddress scratch_addr = align_up(scratch.address(ctx), scratch_align);

    blas_info.dstAccelerationStructure = **blas_;
    blas_info.scratchData.deviceAddress = scratch_addr;
    tlas_info.dstAccelerationStructure = **tlas_;
    tlas_info.scratchData.deviceAddress = scratch_addr;
    ::vk::AccelerationStructureBuildRangeInfoKHR blas_range{.primitiveCount = triangle_count};
    ::vk::AccelerationStructureBuildRangeInfoKHR tlas_range{.primitiveCount = 1};
    ctx.submit_and_wait([&](::vk::CommandBuffer cmd) {
        const ::vk::AccelerationStructureBuildRangeInfoKHR* pb = &blas_range;
        cmd.buildAccelerationStructuresKHR(blas_info, pb, *ctx.device().getDispatcher());
        ::vk::MemoryBarrier barrier{.srcAccessMask = ::vk::AccessFlagBits::eAccelerationStructureWriteKHR,
                                    .dstAccessMask = ::vk::AccessFlagBits::eAccelerationStructureReadKHR};
        cmd.pipelineBarrier(::vk::PipelineStageFlagBits::eAccelerationStructureBuildKHR,
                            ::vk::PipelineStageFlagBits::eAccelerationStructureBuildKHR, {}, barrier, {}, {});
        const ::vk::AccelerationStructureBuildRangeInfoKHR* pt = &tlas_range;
        cmd.buildAccelerationStructuresKHR(tlas_info, pt, *ctx.device().getDispatcher());
    });
    build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace vkmech
