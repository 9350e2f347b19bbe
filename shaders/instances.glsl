// Instances of shape groups (host GpuInstance, BINDING_INSTANCES): what both
// of the GPU kernel's traversals (trace_bvh_gpu.glsl, trace_rayquery.glsl)
// share. FEATURE_INSTANCES is off for every scene without instances, which
// then has none of this code.
#ifndef VKMECH_INSTANCES_GLSL
#define VKMECH_INSTANCES_GLSL

layout(constant_id = SPEC_INSTANCES) const bool FEATURE_INSTANCES = false;
layout(std430, set = 0, binding = BINDING_INSTANCES) readonly buffer Instances { GpuInstance instances[]; };

vec3 affine_point(vec4 r0, vec4 r1, vec4 r2, vec3 p) {
    return vec3(dot(r0.xyz, p) + r0.w, dot(r1.xyz, p) + r1.w, dot(r2.xyz, p) + r2.w);
}
vec3 affine_vector(vec4 r0, vec4 r1, vec4 r2, vec3 v) { return vec3(dot(r0.xyz, v), dot(r1.xyz, v), dot(r2.xyz, v)); }

// A hit in an instance's group, moved to world space (pathtrace.comp, after
// surface_hit): the point and the uv derivatives by the instance's map, the
// normals by its inverse transpose (Mitsuba's instance: no flip for a
// mirroring map), the offset scale bounded by the map's row sums.
#ifdef VKMECH_SCENE_DATA_GLSL
void surface_to_world(inout SurfaceHit s, uint inst) {
    if (!FEATURE_INSTANCES || inst == NO_INSTANCE) return;
    GpuInstance g = instances[inst];
    vec4 r0 = g.to_world[0], r1 = g.to_world[1], r2 = g.to_world[2];
    s.p = affine_point(r0, r1, r2, s.p);
    s.dpdu = affine_vector(r0, r1, r2, s.dpdu);
    s.dpdv = affine_vector(r0, r1, r2, s.dpdv);
    // (M^-1)^T n: the columns of to_local's 3x3 part weighted by n.
    mat3 to_local_t = mat3(g.to_local[0].xyz, g.to_local[1].xyz, g.to_local[2].xyz);
    vec3 ng = to_local_t * s.ng, ns = to_local_t * s.ns;
    s.ng = dot(ng, ng) > 0.0 ? normalize(ng) : ng;
    s.ns = dot(ns, ns) > 0.0 ? normalize(ns) : s.ng;
    if (dot(s.ns, s.ng) < 0.0) s.ng = -s.ng;
    vec3 row_sums = vec3(dot(abs(r0.xyz), vec3(1.0)), dot(abs(r1.xyz), vec3(1.0)), dot(abs(r2.xyz), vec3(1.0)));
    s.scale = max(row_sums.x, max(row_sums.y, row_sums.z)) * s.scale + max(abs(r0.w), max(abs(r1.w), abs(r2.w)));
}
#endif

#endif
