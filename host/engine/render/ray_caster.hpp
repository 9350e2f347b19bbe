// Traces host-given rays on the device (tracerays.comp): the traversal
// agreement test and `vkmech bench traversal`.
#pragma once

#include "render/gpu_scene.hpp"
#include "vk/pipeline.hpp"

namespace vkmech {

// How the rays are handed to the invocations.
enum class RaySchedule {
    // The software BVH on a CPU device (lavapipe): each workgroup traces a slice
    // of the rays, and an invocation whose ray is done takes the slice's next
    // one, so that a SIMD vector does not wait for the slowest ray of a fixed
    // group of eight. Otherwise (ray query; GPUs, where it has not been
    // measured, and where it relies on the warp reconverging at the loop's
    // head) one ray per invocation.
    Auto,
    // One ray per invocation, as the path tracer traces: a SIMD vector or warp
    // runs as long as its slowest ray.
    PerInvocation,
    // Slices on any device with subgroup ballot (software BVH only), so that
    // a GPU can be measured and tested with them (`bench traversal --slices`);
    // asking trace for them where they cannot run is a bug (InternalError).
    Slices,
};

class RayCaster {
public:
    RayCaster(const vk::Context& ctx, const GpuScene& scene);
    // Returns one hit per ray and the seconds the device spent on the dispatch.
    // RaySchedule::Slices only where slices_supported() (else InternalError).
    std::vector<gpu::GpuHit> trace(const std::vector<gpu::GpuRay>& rays, bool any_hit, double* seconds = nullptr,
                                   RaySchedule schedule = RaySchedule::Auto);

    // The software BVH's work per ray for a closest-hit trace (the
    // instrumented shader variant): interior nodes fetched, leaves visited,
    // triangles tested, deepest traversal stack. Software BVH only (a
    // ray-query scene is InternalError).
    struct Work {
        uint32_t nodes, leaves, triangles, stack;
    };
    std::vector<Work> trace_work(const std::vector<gpu::GpuRay>& rays);

    // Whether RaySchedule::Slices can run: the software BVH on a device with subgroup ballot.
    bool slices_supported() const;

private:
    std::vector<gpu::GpuHit> dispatch(const std::vector<gpu::GpuRay>& rays, bool any_hit, bool counters, bool slices,
                                      double* seconds);
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
