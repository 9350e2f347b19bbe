// Hardware (or lavapipe) traversal through VK_KHR_ray_query. The scene is one
// BLAS whose primitive order is the scene triangle order, so gl_PrimitiveID
// names the same triangle as the software BVH.
#ifndef VKMECH_TRACE_RAYQUERY_GLSL
#define VKMECH_TRACE_RAYQUERY_GLSL

#extension GL_EXT_ray_query : require

layout(set = 0, binding = BINDING_TLAS) uniform accelerationStructureEXT tlas;

struct Hit {
    float t;
    uint prim;
    vec2 bary;
    uint inst;  // the GPU kernel: the instance hit (GpuInstance), or NO_INSTANCE; else unset
};

#ifdef KERNEL_GPU
// Instances (FEATURE_INSTANCES): the TLAS holds the ordinary triangles' BLAS
// (custom index TLAS_WORLD) and one instance of its group's BLAS per
// instance (custom index: the instance); a group's primitive i is the scene
// arrays' triangle GpuInstance.info.z + i (host RayTracingAccel).
#include "instances.glsl"
const uint TLAS_WORLD = 0xFFFFFFu;
#endif

bool trace_closest(vec3 o, vec3 d, float tmin, float tmax, out Hit hit) {
    rayQueryEXT rq;
    rayQueryInitializeEXT(rq, tlas, gl_RayFlagsOpaqueEXT, 0xFFu, o, tmin, d, tmax);
    while (rayQueryProceedEXT(rq)) {
    }
    hit.t = tmax;
    hit.prim = 0xFFFFFFFFu;
    hit.bary = vec2(0.0);
    if (rayQueryGetIntersectionTypeEXT(rq, true) == gl_RayQueryCommittedIntersectionTriangleEXT) {
        hit.t = rayQueryGetIntersectionTEXT(rq, true);
        hit.prim = uint(rayQueryGetIntersectionPrimitiveIndexEXT(rq, true));
        hit.bary = rayQueryGetIntersectionBarycentricsEXT(rq, true);
#ifdef KERNEL_GPU
        hit.inst = NO_INSTANCE;
        if (FEATURE_INSTANCES) {
            uint custom = uint(rayQueryGetIntersectionInstanceCustomIndexEXT(rq, true));
            if (custom != TLAS_WORLD) {
                hit.inst = custom;
                hit.prim += instances[custom].info.z;
            }
        }
#endif
        return true;
    }
    return false;
}

bool trace_any(vec3 o, vec3 d, float tmin, float tmax) {
    rayQueryEXT rq;
    rayQueryInitializeEXT(rq, tlas, gl_RayFlagsOpaqueEXT | gl_RayFlagsTerminateOnFirstHitEXT, 0xFFu, o, tmin, d, tmax);
    while (rayQueryProceedEXT(rq)) {
    }
    return rayQueryGetIntersectionTypeEXT(rq, true) != gl_RayQueryCommittedIntersectionNoneEXT;
}

#endif
