// Traces host-given rays on the device (tracerays.comp): the traversal
// agreement test and `vkmech bench traversal`.
#pragma once

#include "render/gpu_scene.hpp"
#include "vk/pipeline.hpp"

namespace vkmech {

class RayCaster {
public:
    RayCaster(const vk::Context& ctx, const GpuScene& scene);
    // Returns one hit per ray and the seconds the device spent on the dispatch.
    std::vector<gpu::GpuHit> trace(const std::vector<gpu::GpuRay>& rays, bool any_hit, double* seconds = nullptr);

private:
    const vk::Context& ctx_;
    const GpuScene& scene_;
};

// Random rays for tests and benchmarks: origins uniform in the scene's box
// (slightly enlarged), directions uniform on the sphere.
std::vector<gpu::GpuRay> random_rays(const SceneArrays& arrays, uint32_t count, uint32_t seed);

}  // namespace vkmech
