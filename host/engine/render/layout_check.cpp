// Guards the host/shader struct layouts of shaders/shared/types.h: std430 and
// std140 lay these structs (vec4/uvec4/mat4 members and 4-byte scalars in
// groups of four) out exactly like C++.
#include "shared/types.h"

#include <cstddef>

namespace vkmech::gpu {
static_assert(sizeof(glm::vec4) == 16 && sizeof(glm::uvec4) == 16 && sizeof(glm::mat4) == 64);
static_assert(sizeof(GpuVertex) == 32);
static_assert(sizeof(GpuMaterial) == MATERIAL_WORDS * 16);
static_assert(sizeof(GpuEmitter) == 32);
static_assert(sizeof(GpuLightTriangle) == 32);
static_assert(sizeof(GpuBvhNode) == 32);
static_assert(sizeof(GpuInstance) == 112);
static_assert(sizeof(GpuEnvironment) == ENV_WORDS * 16);
static_assert(sizeof(GpuDirectional) == 32);
static_assert(sizeof(GpuBvh4Node) == 48);  // 3 RGBA32 texels (shaders/trace_bvh.glsl)
static_assert(sizeof(GpuParams) == 64 + 7 * 16);
static_assert(offsetof(GpuParams, near_clip) == 160);
static_assert(offsetof(GpuParams, window_x0) == 144);
static_assert(sizeof(GpuDebugEvent) == 32);
static_assert(offsetof(GpuParams, tan_half_fov_x) == 64);
static_assert(offsetof(GpuParams, film_width) == 80);    // std140: scalars are 4-aligned, so
static_assert(offsetof(GpuParams, first_sample) == 96);  // each group of four fills one row
static_assert(offsetof(GpuParams, light_triangle_count) == 112);
static_assert(offsetof(GpuParams, active_pixels) == 128);
static_assert(sizeof(GpuPixelAccum) == 9 * 16);
static_assert(offsetof(GpuPixelAccum, bucket_rgb) == 3 * 16);
static_assert(BUCKET_COUNT == 7, "bucket_rgb packs seven RGB sums into six vec4s (shaders/pathtrace.comp)");
static_assert(sizeof(GpuRay) == 32 && sizeof(GpuHit) == 16);
}  // namespace vkmech::gpu
