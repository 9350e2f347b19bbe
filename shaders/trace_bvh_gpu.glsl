// The GPU kernel's software traversal (KERNEL_GPU; included by trace_bvh.glsl,
// which defines Hit, safe_inverse, BVH_MISS, bvh_tri_intersect and the
// counters). The binary SAH tree (host Bvh::nodes, GpuBvhNode) and the
// triangles' positions are storage buffers, read with plain global loads;
// the stack is an ordinary array. On a GPU the CPU kernel's 4-wide quantized
// nodes behind texel fetches, and its stack top kept in eight registers that
// shift on every push and pop, cost registers and occupancy (docs/gpu.md).
#ifndef VKMECH_TRACE_BVH_GPU_GLSL
#define VKMECH_TRACE_BVH_GPU_GLSL

layout(std430, set = 0, binding = BINDING_BVH_NODES) readonly buffer BvhNodes { GpuBvhNode bvh_nodes[]; };
// Three vec4 per triangle (v0, v1, v2) in this tree's order (host
// GpuKernelTree); v0.w: the bits of the triangle's index in the scene arrays.
layout(std430, set = 0, binding = BINDING_BVH_TRIS) readonly buffer BvhTris { vec4 bvh_tri_pos[]; };

// build_bvh's trees are at most kBvhMaxDepth (60) deep, and a level pushes at
// most one node. With instances the host checks that the top-level tree's
// depth, a leaf's entries, the return marker and the deepest group tree fit
// (build_gpu_kernel_tree).
const uint BVH_STACK_SIZE = 64u;

// Instancing (host GpuKernelTree): the scene's shape groups each have a tree
// of their own, in the group's space, after the top-level tree in bvh_nodes
// (and their triangles after its entries in bvh_tri_pos). A top-level leaf
// entry whose first w has INSTANCE_ENTRY_BIT is an instance: the leaf pushes
// it; popped, it pushes BVH_LEAVE_INSTANCE, moves the ray into the group's
// space (the same t: the map is affine and the direction is not
// renormalized) and descends the group's tree; popping BVH_LEAVE_INSTANCE
// restores the world ray. A scene without instances (the constant false)
// runs the one-level traversal unchanged.
#include "instances.glsl"
const uint BVH_LEAVE_INSTANCE = 0xFFFFFFFFu;

// Slab test: the entry distance, or BVH_MISS. Robust to rounding at grazing
// slabs (Ize 2013: the far bound is scaled up).
float bvh_box_entry(vec3 bmin, vec3 bmax, vec3 o, vec3 inv_d, float tmin, float tmax) {
    vec3 t0 = (bmin - o) * inv_d;
    vec3 t1 = (bmax - o) * inv_d;
    vec3 lo = min(t0, t1);
    vec3 hi = max(t0, t1);
    float enter = max(max(lo.x, lo.y), max(lo.z, tmin));
    float leave = min(min(hi.x, hi.y), min(hi.z, tmax)) * 1.0000004;
    return enter <= leave ? enter : BVH_MISS;
}

// Closest hit (any_hit false) or any hit in (tmin, tmax): depth first, the
// nearer child of two first, the other pushed.
bool bvh_trace(vec3 o, vec3 d, float tmin, float tmax, bool any_hit, out Hit hit) {
    hit.t = tmax;
    hit.prim = 0xFFFFFFFFu;
    hit.bary = vec2(0.0);
    hit.inst = NO_INSTANCE;
    const vec3 world_o = o, world_d = d;
    uint inst = NO_INSTANCE;  // the instance whose group's tree the ray is in
    BVH_COUNT(bvh_count_rays += 1u);
    vec3 inv_d = safe_inverse(d);
    uint stack[BVH_STACK_SIZE];
    uint sp = 0u;
    uint node = 0u;
    // Counters (VKMECH_COUNTERS): `nodes` counts box-test steps, the root's
    // box here and each interior node's two children below.
    BVH_COUNT(bvh_count_nodes += 1u);
    if (bvh_box_entry(bvh_nodes[0].bmin.xyz, bvh_nodes[0].bmax.xyz, o, inv_d, tmin, tmax) == BVH_MISS) return false;
    while (true) {
        GpuBvhNode n = bvh_nodes[node];
        uint offset = floatBitsToUint(n.bmin.w);
        uint count = floatBitsToUint(n.bmax.w);
        if (count > 0u) {
            BVH_COUNT(bvh_count_leaves += 1u; bvh_count_tris += count);
            for (uint k = 0u; k < count; ++k) {
                uint i = offset + k;
                vec4 a = bvh_tri_pos[3u * i];
                if (FEATURE_INSTANCES && (floatBitsToUint(a.w) & INSTANCE_ENTRY_BIT) != 0u) {
                    if (sp < BVH_STACK_SIZE) {
                        stack[sp] = floatBitsToUint(a.w);
                        sp += 1u;
                    }
                    continue;
                }
                vec3 v0 = a.xyz;
                float t;
                vec2 uv;
                if (bvh_tri_intersect(v0, bvh_tri_pos[3u * i + 1u].xyz - v0, bvh_tri_pos[3u * i + 2u].xyz - v0, o, d,
                                      tmin, hit.t, t, uv)) {
                    hit.t = t;
                    hit.prim = floatBitsToUint(a.w);
                    hit.bary = uv;
                    hit.inst = inst;
                    if (any_hit) return true;
                }
            }
        } else {
            BVH_COUNT(bvh_count_nodes += 1u);
            uint a = node + 1u;
            uint b = offset;
            GpuBvhNode na = bvh_nodes[a];
            GpuBvhNode nb = bvh_nodes[b];
            float ta = bvh_box_entry(na.bmin.xyz, na.bmax.xyz, o, inv_d, tmin, hit.t);
            float tb = bvh_box_entry(nb.bmin.xyz, nb.bmax.xyz, o, inv_d, tmin, hit.t);
            if (ta < BVH_MISS && tb < BVH_MISS) {
                if (tb < ta) {
                    uint tmp = a;
                    a = b;
                    b = tmp;
                }
                if (sp < BVH_STACK_SIZE) {
                    stack[sp] = b;
                    sp += 1u;
                }
                BVH_COUNT(bvh_count_stack = max(bvh_count_stack, sp));
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
        if (!FEATURE_INSTANCES) {
            if (sp == 0u) break;
            sp -= 1u;
            node = stack[sp];
            continue;
        }
        // Pop past the instances' markers: leave a group's tree, or enter one.
        bool more = false;
        while (sp > 0u) {
            sp -= 1u;
            node = stack[sp];
            if (node < INSTANCE_ENTRY_BIT) {
                more = true;
                break;
            }
            if (node == BVH_LEAVE_INSTANCE) {
                o = world_o;
                d = world_d;
                inst = NO_INSTANCE;
            } else {
                inst = node & ~INSTANCE_ENTRY_BIT;
                GpuInstance g = instances[inst];
                o = affine_point(g.to_local[0], g.to_local[1], g.to_local[2], world_o);
                d = affine_vector(g.to_local[0], g.to_local[1], g.to_local[2], world_d);
                stack[sp] = BVH_LEAVE_INSTANCE;  // in bounds: it replaces the entry just popped
                sp += 1u;
                node = g.info.x;
                more = true;
            }
            inv_d = safe_inverse(d);
            if (more) break;
        }
        if (!more) break;
    }
    return hit.prim != 0xFFFFFFFFu;
}


#endif
