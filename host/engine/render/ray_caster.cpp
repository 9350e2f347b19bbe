#include "render/ray_caster.hpp"

#include "io/invariant.hpp"
#include "render/shader_modules.hpp"
#include "shared/bindings.h"

#include <bit>
#include <chrono>
#include <cmath>
#include <random>

namespace vkmech {

RayCaster::RayCaster(const vk::Context& ctx, const GpuScene& scene) : ctx_(ctx), scene_(scene) {}

std::vector<gpu::GpuHit> RayCaster::trace(const std::vector<gpu::GpuRay>& rays, bool any_hit, double* seconds,
                                          RaySchedule schedule) {
    // `bench traversal --slices` refuses a device or kernel without them (UsageError) before this.
    VKM_ASSERT(schedule != RaySchedule::Slices || slices_supported(),
               scene_.traversal() != Traversal::Bvh ? "the ray kernel's slices exist for the software BVH only"
               : scene_.kernel() != vk::KernelClass::Cpu
                   ? "the ray kernel's slices are the CPU kernel's (--kernel cpu)"
                   : "the ray kernel's slices need subgroup ballot in compute shaders, which " + ctx_.info().name +
                         " does not report");
    const bool slices =
        schedule == RaySchedule::Slices ||
        (schedule == RaySchedule::Auto && scene_.kernel() == vk::KernelClass::Cpu && slices_supported());
    return dispatch(rays, any_hit, false, slices, seconds);
}

bool RayCaster::slices_supported() const {
    // Slices are the CPU kernel's (the GPU kernel's traversal traces one ray per invocation).
    return scene_.traversal() == Traversal::Bvh && scene_.kernel() == vk::KernelClass::Cpu &&
           ctx_.info().compute_subgroup_ballot;
}

std::vector<RayCaster::Work> RayCaster::trace_work(const std::vector<gpu::GpuRay>& rays) {
    VKM_ASSERT(scene_.traversal() != Traversal::RayQuery, "traversal counters exist for the software BVH only");
    std::vector<gpu::GpuHit> raw = dispatch(rays, false, true, false, nullptr);
    std::vector<Work> work(raw.size());
    for (size_t i = 0; i < raw.size(); ++i) {
        const glm::vec4& h = raw[i].hit;
        work[i] = Work{std::bit_cast<uint32_t>(h.x), std::bit_cast<uint32_t>(h.y), std::bit_cast<uint32_t>(h.z),
                       std::bit_cast<uint32_t>(h.w)};
    }
    return work;
}

std::vector<gpu::GpuHit> RayCaster::dispatch(const std::vector<gpu::GpuRay>& rays, bool any_hit, bool counters,
                                             bool slices, double* seconds) {
    using DT = ::vk::DescriptorType;
    using namespace gpu;
    std::vector<vk::BindingDesc> bindings = {{BINDING_RAYS, DT::eStorageBuffer}, {BINDING_HITS, DT::eStorageBuffer}};
    for (const auto& b : traversal_bindings(scene_.traversal(), scene_.kernel())) bindings.push_back(b);
    vk::ComputePipeline pipe(ctx_, tracerays_spirv(scene_.traversal(), scene_.kernel(), counters, slices), bindings,
                             kTraceraysPushBytes, {{SPEC_INSTANCES, scene_.instanced()}});
    vk::Buffer in = vk::Buffer::from_vector(ctx_, rays, ::vk::BufferUsageFlagBits::eStorageBuffer);
    vk::Buffer out(ctx_, std::max<size_t>(16, rays.size() * sizeof(gpu::GpuHit)),
                   ::vk::BufferUsageFlagBits::eStorageBuffer, vk::MemoryUse::Readback);
    pipe.bind_buffer(BINDING_RAYS, in.handle());
    pipe.bind_buffer(BINDING_HITS, out.handle());
    scene_.bind_traversal(pipe);
    pipe.warm_up();  // a lazy driver compiles here, outside the timed dispatch
    // Rays per workgroup of 64 invocations: slices (tracerays.comp) of 2048 rays, 256
    // for each SIMD vector of 8 on lavapipe, long enough that the wait for a slice's
    // last ray is short and few enough that both threads stay busy. A GPU needs far
    // more workgroups to fill its cores: slices of 256 there (not yet measured).
    const uint32_t per_group = !slices ? 64u : ctx_.info().type == "cpu" ? 2048u : 256u;
    uint32_t push[kTraceraysPushBytes / 4] = {static_cast<uint32_t>(rays.size()), any_hit ? 1u : 0u, per_group};
    auto t0 = std::chrono::steady_clock::now();
    ctx_.submit_and_wait([&](::vk::CommandBuffer cmd) {
        pipe.record(cmd, static_cast<uint32_t>((rays.size() + per_group - 1) / per_group), 1, 1, push, sizeof(push));
    });
    if (seconds) *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::vector<gpu::GpuHit> hits(rays.size());
    out.download(ctx_, hits.data(), hits.size() * sizeof(gpu::GpuHit));
    return hits;
}

std::vector<gpu::GpuRay> random_rays(const SceneArrays& arrays, uint32_t count, uint32_t seed) {
    // Fully specified, so that the same seed gives the same rays with every
    // standard library and compiler: std::mt19937's output is fixed by the
    // standard (std::uniform_real_distribution's mapping is not), and the five
    // draws per ray are sequenced (function arguments are not).
    std::mt19937 rng(seed);
    auto U = [&rng] { return static_cast<float>(rng() >> 8) * 0x1p-24f; };  // [0, 1), 24 bits
    glm::vec3 lo = arrays.bbox_lo, hi = arrays.bbox_hi;
    glm::vec3 pad = (hi - lo) * 0.05f;
    lo -= pad;
    hi += pad;
    std::vector<gpu::GpuRay> rays(count);
    for (auto& r : rays) {
        const float ux = U();
        const float uy = U();
        const float uz = U();
        const float uc = U();
        const float up = U();
        glm::vec3 o = lo + (hi - lo) * glm::vec3(ux, uy, uz);
        float z = 1.0f - 2.0f * uc;
        float phi = 6.2831853f * up;
        float s = std::sqrt(std::max(0.0f, 1.0f - z * z));
        glm::vec3 d(s * std::cos(phi), s * std::sin(phi), z);
        r.origin = glm::vec4(o, 0.0f);
        r.direction = glm::vec4(d, 1e30f);
    }
    return rays;
}

}  // namespace vkmech
