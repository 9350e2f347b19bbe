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
};

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
