#version 460
// Traces a buffer of rays and records the closest hits: the traversal
// agreement test and `vkmech bench traversal`. With VKMECH_COUNTERS (software
// BVH only) it records instead the traversal's work per ray, as uint bits:
// interior nodes, leaves, triangles tested, deepest stack
// (`bench traversal --counters`).
#extension GL_GOOGLE_include_directive : require
#include "shared/types.h"
#include "shared/bindings.h"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = BINDING_RAYS) readonly buffer Rays { GpuRay rays[]; };
layout(std430, set = 0, binding = BINDING_HITS) writeonly buffer Hits { GpuHit hits[]; };
layout(push_constant) uniform Push { uint ray_count; uint any_hit; } pc;

#include "traversal.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.ray_count) return;
    GpuRay r = rays[i];
    if (pc.any_hit != 0u) {
        bool occluded = trace_any(r.origin.xyz, r.direction.xyz, r.origin.w, r.direction.w);
        hits[i].hit = vec4(occluded ? 1.0 : -1.0, 0.0, 0.0, 0.0);
        return;
    }
    Hit h;
#ifdef VKMECH_COUNTERS
    trace_closest(r.origin.xyz, r.direction.xyz, r.origin.w, r.direction.w, h);
    hits[i].hit = uintBitsToFloat(uvec4(bvh_count_nodes, bvh_count_leaves, bvh_count_tris, bvh_count_stack));
    return;
#endif
    if (trace_closest(r.origin.xyz, r.direction.xyz, r.origin.w, r.direction.w, h)) {
        hits[i].hit = vec4(h.t, h.bary, uintBitsToFloat(h.prim));
    } else {
        hits[i].hit = vec4(-1.0, 0.0, 0.0, uintBitsToFloat(0xFFFFFFFFu));
    }
}
