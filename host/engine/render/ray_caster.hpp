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
// enlarged by 5% of its size on every side, directions uniform on the
// sphere, tmin 0, tmax 1e30; deterministic for a given seed on every
// platform up to the last bit of std::sin/std::cos (docs/performance.md
// "Traversal versus Embree" spells out the formula).
std::vector<gpu::GpuRay> random_rays(const SceneArrays& arrays, uint32_t count, uint32_t seed);

}  // namespace vkmech
