#version 460
// Traces a buffer of rays and records the closest hits: the traversal
// agreement test and `vkmech bench traversal`. With VKMECH_COUNTERS (software
// BVH only) it records instead the traversal's work per ray, as uint bits:
// interior nodes, leaves, triangles tested, deepest stack
// (`bench traversal --counters`). On the software BVH it traces, unless
// VKMECH_ONE_RAY_PER_INVOCATION, a slice of pc.rays_per_group rays per
// workgroup, an invocation taking the slice's next ray when its own is done
// (bvh_trace_stream; host RaySchedule).
#extension GL_GOOGLE_include_directive : require
#include "shared/types.h"
#include "shared/bindings.h"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = BINDING_RAYS) readonly buffer Rays { GpuRay rays[]; };
layout(std430, set = 0, binding = BINDING_HITS) writeonly buffer Hits { GpuHit hits[]; };
layout(push_constant) uniform Push { uint ray_count; uint any_hit; uint rays_per_group; } pc;

// Ray i's result: any hit, +1 or -1; closest hit, (t, barycentrics, triangle) or
// (-1, 0, 0, no triangle).
void write_hit(uint i, bool found, float t, vec2 bary, uint prim) {
    if (pc.any_hit != 0u) {
        hits[i].hit = vec4(found ? 1.0 : -1.0, 0.0, 0.0, 0.0);
    } else {
        hits[i].hit = found ? vec4(t, bary, uintBitsToFloat(prim)) : vec4(-1.0, 0.0, 0.0, uintBitsToFloat(0xFFFFFFFFu));
    }
}

#if defined(TRAVERSAL_BVH) && !defined(VKMECH_COUNTERS) && !defined(VKMECH_ONE_RAY_PER_INVOCATION) && !defined(KERNEL_GPU)
#extension GL_KHR_shader_subgroup_ballot : require
#define BVH_STREAM
#ifndef BVH_STREAM_REFILL
#define BVH_STREAM_REFILL (gl_SubgroupSize / 2u)
#endif
GpuRay bvh_stream_ray(uint id) { return rays[id]; }
void bvh_stream_hit(uint id, float t, uint prim, vec2 bary) { write_hit(id, prim != 0xFFFFFFFFu, t, bary, prim); }
#endif

#include "traversal.glsl"

void main() {
#ifdef BVH_STREAM
    // This subgroup's share of the workgroup's slice of rays.
    uint first = gl_WorkGroupID.x * pc.rays_per_group;
    uint begin = min(first + gl_SubgroupID * pc.rays_per_group / gl_NumSubgroups, pc.ray_count);
    uint end = min(first + (gl_SubgroupID + 1u) * pc.rays_per_group / gl_NumSubgroups, pc.ray_count);
    bvh_trace_stream(begin, end, pc.any_hit != 0u);
#else
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.ray_count) return;
    GpuRay r = rays[i];
    if (pc.any_hit != 0u) {
        write_hit(i, trace_any(r.origin.xyz, r.direction.xyz, r.origin.w, r.direction.w), 0.0, vec2(0.0), 0u);
        return;
    }
    Hit h;
#ifdef VKMECH_COUNTERS
    trace_closest(r.origin.xyz, r.direction.xyz, r.origin.w, r.direction.w, h);
    hits[i].hit = uintBitsToFloat(uvec4(bvh_count_nodes, bvh_count_leaves, bvh_count_tris, bvh_count_stack));
    return;
#endif
    const bool found = trace_closest(r.origin.xyz, r.direction.xyz, r.origin.w, r.direction.w, h);
    write_hit(i, found, h.t, h.bary, h.prim);
#endif
}
