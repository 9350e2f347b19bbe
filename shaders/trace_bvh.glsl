// Software traversal of the host-built SAH BVH (host/accel/bvh.cpp), for
// devices without VK_KHR_ray_query. Same interface as trace_rayquery.glsl.
#ifndef VKMECH_TRACE_BVH_GLSL
#define VKMECH_TRACE_BVH_GLSL

layout(std430, set = 0, binding = BINDING_BVH_NODES) readonly buffer BvhNodes { GpuBvhNode bvh_nodes[]; };
// Three vec4 per triangle (v0, v1, v2), in BVH order == scene triangle order.
layout(std430, set = 0, binding = BINDING_BVH_TRIS) readonly buffer BvhTris { vec4 bvh_tri_pos[]; };

struct Hit {
    float t;
    uint prim;
    vec2 bary;  // (u, v): p = (1-u-v) v0 + u v1 + v v2
};

const uint BVH_STACK_SIZE = 64u;

vec3 safe_inverse(vec3 d) {
    const float big = 1e30;
    return vec3(abs(d.x) > 1e-30 ? 1.0 / d.x : (d.x >= 0.0 ? big : -big),
                abs(d.y) > 1e-30 ? 1.0 / d.y : (d.y >= 0.0 ? big : -big),
                abs(d.z) > 1e-30 ? 1.0 / d.z : (d.z >= 0.0 ? big : -big));
}

// A box or triangle the ray misses: beyond every t a ray is traced to
// (RAY_TMAX), so a hit at any scene scale is never mistaken for a miss.
const float BVH_MISS = 3.4e38;

// Slab test; returns the entry distance or BVH_MISS when missed.
float bvh_box_entry(vec3 bmin, vec3 bmax, vec3 o, vec3 inv_d, float tmin, float tmax) {
    vec3 t0 = (bmin - o) * inv_d;
    vec3 t1 = (bmax - o) * inv_d;
    vec3 lo = min(t0, t1);
    vec3 hi = max(t0, t1);
    float enter = max(max(lo.x, lo.y), max(lo.z, tmin));
    float leave = min(min(hi.x, hi.y), min(hi.z, tmax));
    // Robust to rounding at grazing slabs (Ize 2013: scale the far bound).
    leave *= 1.0000004;
    return enter <= leave ? enter : BVH_MISS;
}

// Möller–Trumbore, double-sided.
bool bvh_tri_intersect(uint i, vec3 o, vec3 d, float tmin, float tmax, out float t, out vec2 uv) {
    vec3 v0 = bvh_tri_pos[3u * i].xyz;
    vec3 e1 = bvh_tri_pos[3u * i + 1u].xyz - v0;
    vec3 e2 = bvh_tri_pos[3u * i + 2u].xyz - v0;
    vec3 p = cross(d, e2);
    float det = dot(e1, p);
    if (det == 0.0) return false;
    float inv_det = 1.0 / det;
    vec3 s = o - v0;
    float u = dot(s, p) * inv_det;
    if (u < 0.0 || u > 1.0) return false;
    vec3 q = cross(s, e1);
    float v = dot(d, q) * inv_det;
    if (v < 0.0 || u + v > 1.0) return false;
    // q * inv_det is O(1): dot(e2, q) alone is O(coordinate^3) and
    // overflows float for coordinates ~1e13.
    t = dot(e2, q * inv_det);
    if (t <= tmin || t >= tmax) return false;
    uv = vec2(u, v);
    return true;
}

bool bvh_trace(vec3 o, vec3 d, float tmin, float tmax, bool any_hit, out Hit hit) {
    hit.t = tmax;
    hit.prim = 0xFFFFFFFFu;
    hit.bary = vec2(0.0);
    vec3 inv_d = safe_inverse(d);
    uint stack[BVH_STACK_SIZE];
    uint sp = 0u;
    uint node = 0u;
    if (bvh_box_entry(bvh_nodes[0].bmin.xyz, bvh_nodes[0].bmax.xyz, o, inv_d, tmin, tmax) >= BVH_MISS) return false;
    while (true) {
        GpuBvhNode n = bvh_nodes[node];
        uint offset = floatBitsToUint(n.bmin.w);
        uint count = floatBitsToUint(n.bmax.w);
        if (count > 0u) {
            for (uint k = 0u; k < count; ++k) {
                float t;
                vec2 uv;
                if (bvh_tri_intersect(offset + k, o, d, tmin, hit.t, t, uv)) {
                    hit.t = t;
                    hit.prim = offset + k;
                    hit.bary = uv;
                    if (any_hit) return true;
                }
            }
        } else {
            uint a = node + 1u;
            uint b = offset;
            GpuBvhNode na = bvh_nodes[a];
            GpuBvhNode nb = bvh_nodes[b];
            float ta = bvh_box_entry(na.bmin.xyz, na.bmax.xyz, o, inv_d, tmin, hit.t);
            float tb = bvh_box_entry(nb.bmin.xyz, nb.bmax.xyz, o, inv_d, tmin, hit.t);
            if (ta < BVH_MISS && tb < BVH_MISS) {
                // Near child first; push the far one.
                if (tb < ta) { uint tmp = a; a = b; b = tmp; }
                if (sp < BVH_STACK_SIZE) { stack[sp] = b; sp += 1u; }
                node = a;
                continue;
            } else if (ta < BVH_MISS) {
                node = a;
                continue;
            } else if (tb < BVH_MISS) {
                node = b;
                continue;
            }
        }
        if (sp == 0u) break;
        sp -= 1u;
        node = stack[sp];
    }
    return hit.prim != 0xFFFFFFFFu;
}

bool trace_closest(vec3 o, vec3 d, float tmin, float tmax, out Hit hit) {
    return bvh_trace(o, d, tmin, tmax, false, hit);
}

bool trace_any(vec3 o, vec3 d, float tmin, float tmax) {
    Hit h;
    return bvh_trace(o, d, tmin, tmax, true, h);
}

#endif
