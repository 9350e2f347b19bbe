#include "vk/rt_accel.hpp"

#include <chrono>

namespace vkmech {

namespace {
using BU = ::vk::BufferUsageFlagBits;

::vk::DeviceSize align_up(::vk::DeviceSize v, ::vk::DeviceSize a) { return (v + a - 1) / a * a; }

// Custom index of the TLAS instance of the ordinary triangles' BLAS (shaders/trace_rayquery.glsl TLAS_WORLD).
constexpr uint32_t kTlasWorld = 0xFFFFFFu;
}  // namespace

RayTracingAccel::RayTracingAccel(const vk::Context& ctx, const vk::Buffer& positions, uint32_t triangle_count)
    : RayTracingAccel(ctx, positions, triangle_count, {}, {}) {}

RayTracingAccel::RayTracingAccel(const vk::Context& ctx, const vk::Buffer& positions, uint32_t triangle_count,
                                 const std::vector<glm::uvec2>& group_triangles,
                                 const std::vector<gpu::GpuInstance>& instances) {
    if (!ctx.ray_query_enabled())
        throw vk::VulkanError("ray-query acceleration requested on a device without VK_KHR_ray_query");
    if (instances.size() >= kTlasWorld)
        throw vk::VulkanError("ray query takes at most " + std::to_string(kTlasWorld - 1) +
                              " instances (a 24-bit custom index); use --traversal bvh");
    auto t0 = std::chrono::steady_clock::now();
    const auto& dev = ctx.device();
    auto as_props =
        ctx.physical()
            .getProperties2<::vk::PhysicalDeviceProperties2, ::vk::PhysicalDeviceAccelerationStructurePropertiesKHR>()
            .get<::vk::PhysicalDeviceAccelerationStructurePropertiesKHR>();
    const ::vk::DeviceSize scratch_align =
        std::max<::vk::DeviceSize>(as_props.minAccelerationStructureScratchOffsetAlignment, 16);

    // ---- BLAS: the ordinary triangles [0, world), then each shape group's range ----
    const uint32_t world = group_triangles.empty() ? triangle_count : group_triangles.front().x;
    struct Blas {
        uint32_t first = 0, count = 0;
        ::vk::AccelerationStructureGeometryKHR geom;
        ::vk::AccelerationStructureBuildGeometryInfoKHR info;
        ::vk::AccelerationStructureBuildSizesInfoKHR sizes;
    };
    std::vector<Blas> blas;
    std::vector<int> group_blas(group_triangles.size(), -1);
    auto add_blas = [&](uint32_t first, uint32_t count) {
        Blas b;
        b.first = first;
        b.count = count;
        ::vk::AccelerationStructureGeometryTrianglesDataKHR tri{
            .vertexFormat = ::vk::Format::eR32G32B32Sfloat,
            .vertexData = ::vk::DeviceOrHostAddressConstKHR{.deviceAddress = positions.address(ctx) +
                                                                             ::vk::DeviceSize{first} * 3 * 16},
            .vertexStride = sizeof(float) * 4,
            .maxVertex = count * 3 - 1,
            .indexType = ::vk::IndexType::eNoneKHR};
        b.geom = ::vk::AccelerationStructureGeometryKHR{
            .geometryType = ::vk::GeometryTypeKHR::eTriangles,
            .geometry = ::vk::AccelerationStructureGeometryDataKHR{.triangles = tri},
            .flags = ::vk::GeometryFlagBitsKHR::eOpaque};
        blas.push_back(b);
    };
    if (world > 0) add_blas(0, world);
    for (size_t g = 0; g < group_triangles.size(); ++g)
        if (group_triangles[g].y > 0) {
            group_blas[g] = static_cast<int>(blas.size());
            add_blas(group_triangles[g].x, group_triangles[g].y);
        }
    ::vk::DeviceSize scratch_size = 0;
    for (auto& b : blas) {
        b.info = ::vk::AccelerationStructureBuildGeometryInfoKHR{
            .type = ::vk::AccelerationStructureTypeKHR::eBottomLevel,
            .flags = ::vk::BuildAccelerationStructureFlagBitsKHR::ePreferFastTrace,
            .mode = ::vk::BuildAccelerationStructureModeKHR::eBuild,
            .geometryCount = 1,
            .pGeometries = &b.geom};
        b.sizes = dev.getAccelerationStructureBuildSizesKHR(::vk::AccelerationStructureBuildTypeKHR::eDevice, b.info,
                                                            {b.count});
        blas_buffers_.emplace_back(ctx, b.sizes.accelerationStructureSize,
                                   BU::eAccelerationStructureStorageKHR | BU::eShaderDeviceAddress,
                                   vk::MemoryUse::Device);
        blas_.push_back(std::make_unique<::vk::raii::AccelerationStructureKHR>(
            dev, ::vk::AccelerationStructureCreateInfoKHR{.buffer = blas_buffers_.back().handle(),
                                                          .size = b.sizes.accelerationStructureSize,
                                                          .type = ::vk::AccelerationStructureTypeKHR::eBottomLevel}));
        b.info.dstAccelerationStructure = **blas_.back();
        scratch_size = std::max(scratch_size, b.sizes.buildScratchSize);
    }
    auto address = [&](size_t b) {
        return dev.getAccelerationStructureAddressKHR(
            ::vk::AccelerationStructureDeviceAddressInfoKHR{.accelerationStructure = **blas_[b]});
    };

    // ---- TLAS: the ordinary triangles (identity), then each instance of a group ----
    std::vector<::vk::AccelerationStructureInstanceKHR> tlas_instances;
    auto add_instance = [&](const float(&rows)[3][4], uint32_t custom, size_t b) {
        ::vk::AccelerationStructureInstanceKHR inst{};
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) inst.transform.matrix[r][c] = rows[r][c];
        inst.instanceCustomIndex = custom;
        inst.mask = 0xFF;
        inst.flags =
            static_cast<VkGeometryInstanceFlagsKHR>(::vk::GeometryInstanceFlagBitsKHR::eTriangleFacingCullDisable);
        inst.accelerationStructureReference = address(b);
        tlas_instances.push_back(inst);
    };
    if (world > 0) {
        const float identity[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
        add_instance(identity, kTlasWorld, 0);
    }
    for (size_t j = 0; j < instances.size(); ++j) {
        const int b = group_blas.at(instances[j].info.y);
        if (b < 0) continue;
        float rows[3][4];
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) rows[r][c] = instances[j].to_world[r][c];
        add_instance(rows, static_cast<uint32_t>(j), static_cast<size_t>(b));
    }
    const uint32_t tlas_count = static_cast<uint32_t>(tlas_instances.size());
    instances_ =
        vk::Buffer(ctx, std::max<size_t>(1, tlas_count) * sizeof(::vk::AccelerationStructureInstanceKHR),
                   BU::eAccelerationStructureBuildInputReadOnlyKHR | BU::eShaderDeviceAddress | BU::eTransferDst,
                   vk::MemoryUse::Device);
    if (tlas_count > 0)
        instances_.upload(ctx, tlas_instances.data(), tlas_count * sizeof(::vk::AccelerationStructureInstanceKHR));
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
    auto tlas_sizes = dev.getAccelerationStructureBuildSizesKHR(::vk::AccelerationStructureBuildTypeKHR::eDevice,
                                                                tlas_info, {tlas_count});
    tlas_buffer_ = vk::Buffer(ctx, tlas_sizes.accelerationStructureSize,
                              BU::eAccelerationStructureStorageKHR | BU::eShaderDeviceAddress, vk::MemoryUse::Device);
    tlas_ = std::make_unique<::vk::raii::AccelerationStructureKHR>(
        dev, ::vk::AccelerationStructureCreateInfoKHR{.buffer = tlas_buffer_.handle(),
                                                      .size = tlas_sizes.accelerationStructureSize,
                                                      .type = ::vk::AccelerationStructureTypeKHR::eTopLevel});

    scratch_size = align_up(std::max(scratch_size, tlas_sizes.buildScratchSize), scratch_align) + scratch_align;
    vk::Buffer scratch(ctx, scratch_size, BU::eStorageBuffer | BU::eShaderDeviceAddress, vk::MemoryUse::Device);
    ::vk::DeviceAddress scratch_addr = align_up(scratch.address(ctx), scratch_align);
    tlas_info.dstAccelerationStructure = **tlas_;
    tlas_info.scratchData.deviceAddress = scratch_addr;
    ::vk::AccelerationStructureBuildRangeInfoKHR tlas_range{.primitiveCount = tlas_count};
    ctx.submit_and_wait([&](::vk::CommandBuffer cmd) {
        // One scratch buffer: each build waits for the one before.
        ::vk::MemoryBarrier barrier{.srcAccessMask = ::vk::AccessFlagBits::eAccelerationStructureWriteKHR,
                                    .dstAccessMask = ::vk::AccessFlagBits::eAccelerationStructureReadKHR |
                                                     ::vk::AccessFlagBits::eAccelerationStructureWriteKHR};
        for (auto& b : blas) {
            b.info.scratchData.deviceAddress = scratch_addr;
            ::vk::AccelerationStructureBuildRangeInfoKHR range{.primitiveCount = b.count};
            const ::vk::AccelerationStructureBuildRangeInfoKHR* pb = &range;
            cmd.buildAccelerationStructuresKHR(b.info, pb, *ctx.device().getDispatcher());
            cmd.pipelineBarrier(::vk::PipelineStageFlagBits::eAccelerationStructureBuildKHR,
                                ::vk::PipelineStageFlagBits::eAccelerationStructureBuildKHR, {}, barrier, {}, {});
        }
        const ::vk::AccelerationStructureBuildRangeInfoKHR* pt = &tlas_range;
        cmd.buildAccelerationStructuresKHR(tlas_info, pt, *ctx.device().getDispatcher());
    });
    build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace vkmech
