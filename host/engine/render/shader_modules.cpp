#include "render/shader_modules.hpp"
#include "io/invariant.hpp"

#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "shaders/spv_pathtrace_bvh.h"
#include "shaders/spv_pathtrace_bvh_gpu.h"
#include "shaders/spv_pathtrace_bvh_gpu_direct.h"
#include "shaders/spv_pathtrace_counters_bvh.h"
#include "shaders/spv_pathtrace_counters_bvh_gpu.h"
#include "shaders/spv_pathtrace_direct_glossy_bvh.h"
#include "shaders/spv_pathtrace_direct_glossy_bvh_gpu.h"
#include "shaders/spv_pathtrace_direct_glossy_rayquery.h"
#include "shaders/spv_pathtrace_direct_glossy_rayquery_gpu.h"
#include "shaders/spv_pathtrace_rayquery.h"
#include "shaders/spv_pathtrace_rayquery_gpu.h"
#include "shaders/spv_tracerays_bvh.h"
#include "shaders/spv_tracerays_bvh_gpu.h"
#include "shaders/spv_tracerays_counters_bvh.h"
#include "shaders/spv_tracerays_counters_bvh_gpu.h"
#include "shaders/spv_tracerays_per_invocation_bvh.h"
#include "shaders/spv_tracerays_rayquery.h"

namespace vkmech {

namespace {

bool gpu_kernel(vk::KernelClass k) {
    VKM_ASSERT(k != vk::KernelClass::Auto, "shader modules: the kernel class is not resolved");
    return k == vk::KernelClass::Gpu;
}

}  // namespace

GpuTally gpu_tally_from_env() {
    const char* env = std::getenv("VKMECH_GPU_TALLY");
    const std::string v = env ? env : "";
    if (v.empty() || v == "registers") return GpuTally::Registers;
    if (v == "shared") return GpuTally::Shared;
    if (v == "direct") return GpuTally::Direct;
    throw std::invalid_argument("VKMECH_GPU_TALLY='" + v +
                                "': expected 'registers' (the default), 'shared' or 'direct'");
}

std::span<const uint32_t> pathtrace_spirv(Traversal t, vk::KernelClass k) {
    const bool g = gpu_kernel(k);
    if (g && t == Traversal::Bvh && gpu_tally_from_env() == GpuTally::Direct) return spv_pathtrace_bvh_gpu_direct;
    if (t == Traversal::RayQuery)
        return g ? std::span<const uint32_t>(spv_pathtrace_rayquery_gpu) : spv_pathtrace_rayquery;
    return g ? std::span<const uint32_t>(spv_pathtrace_bvh_gpu) : spv_pathtrace_bvh;
}

std::span<const uint32_t> pathtrace_spirv(Traversal t, vk::KernelClass k, bool direct_glossy, bool counters) {
    const bool g = gpu_kernel(k);
    if (counters) {
        VKM_ASSERT(t == Traversal::Bvh && !direct_glossy,
                   "traversal counters exist for the software BVH's default path tracer only");
        return g ? std::span<const uint32_t>(spv_pathtrace_counters_bvh_gpu) : spv_pathtrace_counters_bvh;
    }
    if (!direct_glossy) return pathtrace_spirv(t, k);
    if (t == Traversal::RayQuery)
        return g ? std::span<const uint32_t>(spv_pathtrace_direct_glossy_rayquery_gpu)
                 : spv_pathtrace_direct_glossy_rayquery;
    return g ? std::span<const uint32_t>(spv_pathtrace_direct_glossy_bvh_gpu) : spv_pathtrace_direct_glossy_bvh;
}

std::span<const uint32_t> tracerays_spirv(Traversal t, vk::KernelClass k, bool counters, bool slices) {
    const bool g = gpu_kernel(k);
    if (t == Traversal::RayQuery) {
        VKM_ASSERT(!counters, "traversal counters exist for the software BVH only");
        return spv_tracerays_rayquery;  // reads no scene array: one module for both kernels
    }
    if (g) return counters ? std::span<const uint32_t>(spv_tracerays_counters_bvh_gpu) : spv_tracerays_bvh_gpu;
    if (counters) return spv_tracerays_counters_bvh;
    if (slices) return spv_tracerays_bvh;
    return spv_tracerays_per_invocation_bvh;
}

}  // namespace vkmech
