// The embedded SPIR-V modules (compiled at build time by glslangValidator).
#pragma once

#include "render/gpu_scene.hpp"
#include "vk/context.hpp"

#include <span>

namespace vkmech {

// The path tracer of a traversal and kernel class (vk::KernelClass, resolved:
// not Auto): the default module (what the studies' code digest hashes) and,
// with `direct_glossy`, the variant compiled with VKMECH_DIRECT_GLOSSY
// (docs/descriptor.md §3.4). The Cpu kernel's modules are the ones vkmech had
// before the split, byte for byte.
// With VKMECH_GPU_TALLY=direct (gpu_tally_from_env), the Gpu kernel's software-BVH module is the
// direct-tally one (VKMECH_DIRECT_TALLY, docs/gpu.md); ray query keeps the register tally.
std::span<const uint32_t> pathtrace_spirv(Traversal t, vk::KernelClass k);
// `counters`: the instrumented variant (VKMECH_COUNTERS; software BVH, not with direct_glossy;
// InternalError otherwise).
std::span<const uint32_t> pathtrace_spirv(Traversal t, vk::KernelClass k, bool direct_glossy, bool counters = false);
// VKMECH_GPU_TALLY=registers|shared|direct: where the GPU kernel keeps its bucket tally (docs/gpu.md).
// A measurement switch for GPU sessions; the Cpu kernel has one layout and ignores it. Unset or empty:
// registers; std::invalid_argument for anything else.
enum class GpuTally { Registers, Shared, Direct };
GpuTally gpu_tally_from_env();
// The ray tracer of tests and benchmarks; `counters`: the instrumented variant
// (VKMECH_COUNTERS, software BVH only; InternalError for ray query).
// `slices` (software BVH, Cpu kernel, not counters): the kernel that gives each
// workgroup a slice of the rays (needs subgroup ballot); else one ray per
// invocation. The Gpu kernel traces one ray per invocation.
std::span<const uint32_t> tracerays_spirv(Traversal t, vk::KernelClass k, bool counters = false, bool slices = true);
// The size of tracerays.comp's push constants (ray_count, any_hit, rays_per_group).
inline constexpr uint32_t kTraceraysPushBytes = 12;

}  // namespace vkmech
