// Descriptor bindings (set 0) and specialization-constant ids of the compute
// entries, shared by GLSL (layout qualifiers) and C++ (host/engine/render:
// pipeline layouts, descriptor writes, spec_constants()).
#ifndef VKMECH_SHARED_BINDINGS_H
#define VKMECH_SHARED_BINDINGS_H

#ifdef __cplusplus
#include <cstdint>
namespace vkmech::gpu {
#define VKM_ID static constexpr uint32_t
#else
#define VKM_ID const uint
#endif

// Descriptor bindings: pathtrace.comp uses all but RAYS and HITS,
// tracerays.comp uses RAYS, HITS and the traversal's (TLAS or BVH_*).
VKM_ID BINDING_PARAMS = 0u;
VKM_ID BINDING_VERTICES = 1u;
VKM_ID BINDING_TRIANGLES = 2u;
VKM_ID BINDING_MATERIALS = 3u;
VKM_ID BINDING_LIGHT_TRIS = 4u;
VKM_ID BINDING_EMITTERS = 5u;
VKM_ID BINDING_ACCUM = 6u;
VKM_ID BINDING_TLAS = 7u;
VKM_ID BINDING_BVH_NODES = 8u;
VKM_ID BINDING_BVH_TRIS = 9u;
VKM_ID BINDING_RAYS = 10u;
VKM_ID BINDING_HITS = 11u;
VKM_ID BINDING_TEXELS = 12u;
VKM_ID BINDING_TEXTURES = 13u;
VKM_ID BINDING_DEBUG = 14u;
VKM_ID BINDING_SAMPLE_COUNTS = 15u;
VKM_ID BINDING_COUNTERS = 16u;  // pathtrace.comp's VKMECH_COUNTERS variant only (bench render --profile --counters)
VKM_ID BINDING_WORK = 17u;      // pathtrace.comp: the pixel-slot counter of claimed pixels (params.claimed_pixels)
VKM_ID BINDING_ENVIRONMENT = 18u;  // the emitters at infinity (shared/types.h GpuEnvironment)
VKM_ID BINDING_INSTANCES = 19u;    // the GPU kernel's software BVH: the instances of shape groups (GpuInstance)
VKM_ID BINDING_TAXONOMY = 20u;     // pathtrace.comp: a user taxonomy's DFA (shared/types.h TAX_*), when SPEC_TAXONOMY

// Specialization-constant ids (layout(constant_id = ...)).
// 1..5, 12 and 19: the material features, SPEC_<NAME> of shared/materials.h.
VKM_ID SPEC_THIN_LENS = 0u;             // camera.glsl
VKM_ID SPEC_TEXTURES = 6u;              // features.glsl, 6..7
VKM_ID SPEC_CAPTURE = 7u;
VKM_ID SPEC_ESTIMATOR = 8u;             // pathtrace.comp, 8..10
VKM_ID SPEC_DEBUG_EVENTS = 9u;
VKM_ID SPEC_END_VERTEX_LITERAL = 10u;
VKM_ID SPEC_ORTHOGRAPHIC = 11u;         // camera.glsl
VKM_ID SPEC_ENVIRONMENT = 13u;          // features.glsl: emitters at infinity
VKM_ID SPEC_SHARED_TALLY = 14u;         // pathtrace.comp, GPU kernel only: the bucket tally in shared memory
VKM_ID SPEC_INSTANCES = 15u;            // trace_bvh_gpu.glsl: the scene has instances (a two-level tree)
VKM_ID SPEC_WINDOW = 16u;               // pathtrace.comp: the film is a window of the full film (--pixel-bounds)
VKM_ID SPEC_TANGENTS = 17u;             // features.glsl: meshes with the file's tangents (glTF TANGENT)
VKM_ID SPEC_TAXONOMY = 18u;             // pathtrace.comp: events classified by a user taxonomy (--taxonomy)

#ifdef __cplusplus
}  // namespace vkmech::gpu
#endif
#undef VKM_ID

#endif
