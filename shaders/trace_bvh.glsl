// Software traversal of the host-built SAH BVH (host/engine/accel/bvh.cpp), for
// devices without VK_KHR_ray_query. Same interface as trace_rayquery.glsl.
// Two kernels (docs/gpu.md, "Two kernels"): the CPU kernel's below, tuned on
// lavapipe; with KERNEL_GPU, trace_bvh_gpu.glsl's, tuned on a GPU. They share
// the hit record, the triangle test and the counters.
#ifndef VKMECH_TRACE_BVH_GLSL
#define VKMECH_TRACE_BVH_GLSL

#ifndef KERNEL_GPU
#extension GL_EXT_samplerless_texture_functions : require

// Both are uniform texel buffers of RGBA32 uint texels (a texel fetch loads
// a whole vec4 per invocation on lavapipe, where a storage-buffer load at a
// divergent address loads every component of every invocation on its own;
// docs/performance.md): the 4-wide nodes are three texels each
// (GpuBvh4Node: origin, exponents and child codes; two of quantized bounds,
// the first child node and triangle),
// the triangles three (v0, v1, v2; xyz are float bits), in
// BVH order == scene triangle order. The three w components hold a fourth
// vertex d where triangle i = (a, b, c) and triangle i + 1 = (a, c, d) form a
// quad in the same leaf (host Bvh::quad_next), else the bits of a: one fetch
// of three texels then tests both triangles of a quad.
layout(set = 0, binding = BINDING_BVH_NODES) uniform utextureBuffer bvh_nodes;
layout(set = 0, binding = BINDING_BVH_TRIS) uniform utextureBuffer bvh_tri_pos;

// Byte k of each component of q, for the four children.
vec4 bvh_bytes(uint q) { return vec4((uvec4(q) >> uvec4(0u, 8u, 16u, 24u)) & 0xFFu); }
#endif

struct Hit {
    float t;
    uint prim;
    vec2 bary;  // (u, v): p = (1-u-v) v0 + u v1 + v v2
    uint inst;  // the GPU kernel: the instance hit (GpuInstance), or NO_INSTANCE; else unset
};

vec3 safe_inverse(vec3 d) {
    const float big = 1e30;
    return vec3(abs(d.x) > 1e-30 ? 1.0 / d.x : (d.x >= 0.0 ? big : -big),
                abs(d.y) > 1e-30 ? 1.0 / d.y : (d.y >= 0.0 ? big : -big),
                abs(d.z) > 1e-30 ? 1.0 / d.z : (d.z >= 0.0 ? big : -big));
}

// A box or triangle the ray misses: beyond every t a ray is traced to
// (RAY_TMAX), so a hit at any scene scale is never mistaken for a miss.
const float BVH_MISS = 3.4e38;

// Möller–Trumbore, double-sided, on the triangle (v0, v0 + e1, v0 + e2).
bool bvh_tri_intersect(vec3 v0, vec3 e1, vec3 e2, vec3 o, vec3 d, float tmin, float tmax, out float t, out vec2 uv) {
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

#ifdef VKMECH_COUNTERS
// The instrumented variants (tracerays.comp, pathtrace.comp with
// VKMECH_COUNTERS): the work of every trace of this invocation, summed.
uint bvh_count_rays = 0u;    // traces (closest-hit and shadow rays)
uint bvh_count_nodes = 0u;   // interior nodes fetched (four child boxes tested each)
uint bvh_count_leaves = 0u;  // leaves visited
uint bvh_count_tris = 0u;    // triangles tested
uint bvh_count_stack = 0u;   // deepest stack
#define BVH_COUNT(stmt) stmt
#else
#define BVH_COUNT(stmt)
#endif

#ifdef KERNEL_GPU
#include "trace_bvh_gpu.glsl"
#else
// Orders two (distance, child) pairs by distance.
void bvh_order(inout float da, inout uint ca, inout float db, inout uint cb) {
    bool swap = db < da;
    float t = da;
    uint c = ca;
    da = swap ? db : da;
    ca = swap ? cb : ca;
    db = swap ? t : db;
    cb = swap ? c : cb;
}

// Push and pop on bvh_trace's stack (registers s0..s7 over memory). A push
// shifts the registers down; the register that falls off the bottom has been
// written to memory before (BVH_SPILL). A pop shifts them up and refills s7
// from memory. On lavapipe an `if` whose body is a single short block runs
// for every invocation (masked) whether or not any needs it, and a store or
// load at a per-invocation index into the memory part is a loop over the
// SIMD vector's invocations; so BVH_SPILL and the refill are written as
// blocks with a second condition inside (the stack bound, which the tree
// never reaches: collapse_bvh4 checks it), which lavapipe branches over when
// no invocation of the vector needs memory (docs/performance.md).
#define BVH_PUSH(x)                                   \
    {                                                 \
        s7 = s6; s6 = s5; s5 = s4; s4 = s3;           \
        s3 = s2; s2 = s1; s1 = s0; s0 = (x);          \
        sp += 1u;                                     \
    }
// Before n pushes: the registers s7, s6, s5 (in that order) fall off the
// bottom of the register part once the stack holds eight or more entries.
#define BVH_SPILL(n)                                                        \
    {                                                                       \
        if (sp + (n) > 8u) {                                                \
            if (sp + 3u <= BVH4_STACK_SIZE) {                               \
                if (sp >= 8u) stack[sp - 8u] = s7;                          \
                if (sp >= 7u && (n) >= 2u) stack[sp - 7u] = s6;             \
                if (sp >= 6u && (n) >= 3u) stack[sp - 6u] = s5;             \
            }                                                               \
        }                                                                   \
    }
#define BVH_POP(dst)                                  \
    {                                                 \
        dst = s0;                                     \
        s0 = s1; s1 = s2; s2 = s3; s3 = s4;           \
        s4 = s5; s5 = s6; s6 = s7;                    \
        sp -= 1u;                                     \
        if (sp >= 8u) {                               \
            if (sp < BVH4_STACK_SIZE) s7 = stack[sp - 8u]; \
        }                                             \
    }

// Closest hit (any_hit false) or any hit in (tmin, tmax). Interior nodes are
// visited until the ray reaches a leaf or runs out of work, then the leaf's
// triangles are tested, so that the invocations of a SIMD group test
// triangles together. A node's four child boxes are tested at once; the hit
// children are visited near to far (the nearest next, the others pushed far
// first). Slab test robust to rounding at grazing slabs (Ize 2013: the far
// bound is scaled up).
//
// With BVH_STREAM (tracerays.comp on CPU devices) the same traversal is
// bvh_trace_stream instead, which traces the rays [begin, end) of a buffer
// with the invocations of one subgroup: an invocation whose ray is done
// waits until BVH_STREAM_REFILL of them are, then they write their hits
// (bvh_stream_hit) and take the next rays (bvh_stream_ray) together, so that
// a SIMD vector no longer runs as long as the slowest of a fixed group of
// rays. It relies on the subgroup's invocations meeting at the loop's head
// (lavapipe runs them as one masked vector).
#ifdef BVH_STREAM
void bvh_trace_stream(uint begin, uint end, bool any_hit) {
    uint next = begin;  // the slice's first ray not yet taken (the same in every invocation)
    uint id = 0xFFFFFFFFu;
    vec3 o = vec3(0.0), d = vec3(0.0), inv_d = vec3(0.0);
    bvec3 neg = bvec3(false);
    float tmin = 0.0;
    Hit hit;
    hit.t = 0.0;
    hit.prim = 0xFFFFFFFFu;
    hit.bary = vec2(0.0);
#else
bool bvh_trace(vec3 o, vec3 d, float tmin, float tmax, bool any_hit, out Hit hit) {
    hit.t = tmax;
    hit.prim = 0xFFFFFFFFu;
    hit.bary = vec2(0.0);
    BVH_COUNT(bvh_count_rays += 1u);
    vec3 inv_d = safe_inverse(d);
    bvec3 neg = lessThan(inv_d, vec3(0.0));  // the far plane is a box's lower bound on these axes
#endif
    // The stack's top eight entries live in registers (s0 the top), the rest
    // in memory: a push or pop is eight vector selects, and only a stack
    // deeper than eight touches memory (per invocation on lavapipe).
    uint stack[BVH4_STACK_SIZE - 8u];
    uint sp = 0u;
    uint s0 = 0u, s1 = 0u, s2 = 0u, s3 = 0u, s4 = 0u, s5 = 0u, s6 = 0u, s7 = 0u;
    const uint DONE = 0xFFFFFFFFu;
#ifdef BVH_STREAM
    uint ref = DONE;
    for (;;) {
        // The invocations here: the whole subgroup, where it meets again at the
        // loop's head (lavapipe). Where a device did not reconverge, the test
        // against those present, not against the subgroup's size, keeps a part
        // whose invocations are all idle from waiting forever for the others.
        // The parts would then number rays each from its own `next`: rays
        // traced twice (same hits, lower throughput) or, should the parts meet
        // again out of step, skipped (the batch test's every-ray check).
        const uint present = subgroupBallotBitCount(subgroupBallot(true));
        uvec4 idle = subgroupBallot(ref == DONE);
        uint n = subgroupBallotBitCount(idle);
        if (n >= (next < end ? clamp(BVH_STREAM_REFILL, 1u, present) : present)) {
            if (ref == DONE) {
                if (id != DONE) bvh_stream_hit(id, hit.t, hit.prim, hit.bary);
                id = next + subgroupBallotExclusiveBitCount(idle);
                if (id < end) {
                    GpuRay r = bvh_stream_ray(id);
                    o = r.origin.xyz;
                    d = r.direction.xyz;
                    tmin = r.origin.w;
                    hit.t = r.direction.w;
                    hit.prim = DONE;
                    hit.bary = vec2(0.0);
                    inv_d = safe_inverse(d);
                    neg = lessThan(inv_d, vec3(0.0));
                    sp = 0u;
                    ref = 0u;
                } else {
                    id = DONE;
                }
            }
            if (next >= end) break;
            next += n;
        }
#else
    uint ref = 0u;  // the root: interior node 0
    while (ref != DONE) {
#endif
        while (ref != DONE && (ref >> BVH4_COUNT_SHIFT) == 0u) {
            BVH_COUNT(bvh_count_nodes += 1u);
            uvec4 head = texelFetch(bvh_nodes, int(3u * ref));
            uvec4 q0 = texelFetch(bvh_nodes, int(3u * ref + 1u));
            uvec4 q1 = texelFetch(bvh_nodes, int(3u * ref + 2u));
            // The children (GpuBvh4Node): interior ones are consecutive nodes
            // from first_node, leaves consecutive triangles from first_tri.
            uvec4 code = uvec4(head.w >> 24u, head.w >> 28u, q1.z >> 28u, q1.w >> 28u) & 0xFu;
            uvec4 interior = uvec4(equal(code, uvec4(BVH4_CODE_INTERIOR)));
            uvec4 tris = max(code, uvec4(1u)) - 1u;  // a leaf's triangle count, else 0
            uvec4 child = mix(
                (uvec4(q1.w & BVH4_INDEX_MASK) + uvec4(0u, tris.x, tris.x + tris.y, tris.x + tris.y + tris.z)) |
                    (tris << BVH4_COUNT_SHIFT),
                uvec4(q1.z & BVH4_INDEX_MASK) +
                    uvec4(0u, interior.x, interior.x + interior.y, interior.x + interior.y + interior.z),
                bvec4(interior));
            // Decode: bound = origin + q * 2^(e - 127), exact products (collapse_bvh4).
            vec3 org = uintBitsToFloat(head.xyz);
            vec3 step = uintBitsToFloat(((uvec3(head.w) >> uvec3(0u, 8u, 16u)) & 0xFFu) << 23u);
            // The near and far planes by the ray's direction signs, picked on
            // the packed bytes (one select covers four children): the slab's
            // entry and exit are then the near and far distances, with no
            // min/max between them.
            uint nx = neg.x ? q0.w : q0.x, fx = neg.x ? q0.x : q0.w;
            uint ny = neg.y ? q1.x : q0.y, fy = neg.y ? q0.y : q1.x;
            uint nz = neg.z ? q1.y : q0.z, fz = neg.z ? q0.z : q1.y;
            vec4 tnx = (org.x + bvh_bytes(nx) * step.x - o.x) * inv_d.x, tfx = (org.x + bvh_bytes(fx) * step.x - o.x) * inv_d.x;
            vec4 tny = (org.y + bvh_bytes(ny) * step.y - o.y) * inv_d.y, tfy = (org.y + bvh_bytes(fy) * step.y - o.y) * inv_d.y;
            vec4 tnz = (org.z + bvh_bytes(nz) * step.z - o.z) * inv_d.z, tfz = (org.z + bvh_bytes(fz) * step.z - o.z) * inv_d.z;
            vec4 enter = max(max(tnx, tny), max(tnz, vec4(tmin)));
            vec4 leave = min(min(tfx, tfy), min(tfz, vec4(hit.t))) * 1.0000004;
            bvec4 hits = bvec4(uvec4(lessThanEqual(enter, leave)) & uvec4(notEqual(code, uvec4(BVH4_CODE_EMPTY))));
            float d0 = hits.x ? enter.x : BVH_MISS, d1 = hits.y ? enter.y : BVH_MISS;
            float d2 = hits.z ? enter.z : BVH_MISS, d3 = hits.w ? enter.w : BVH_MISS;
            uint c0 = child.x, c1 = child.y, c2 = child.z, c3 = child.w;
            bvh_order(d0, c0, d1, c1);
            bvh_order(d2, c2, d3, c3);
            bvh_order(d0, c0, d2, c2);
            bvh_order(d1, c1, d3, c3);
            bvh_order(d1, c1, d2, c2);
            if (d0 < BVH_MISS) {
                ref = c0;
                // The hit children are sorted first: c1 .. cn are pushed.
                BVH_SPILL(uint(d1 < BVH_MISS) + uint(d2 < BVH_MISS) + uint(d3 < BVH_MISS));
                if (d3 < BVH_MISS) BVH_PUSH(c3);
                if (d2 < BVH_MISS) BVH_PUSH(c2);
                if (d1 < BVH_MISS) BVH_PUSH(c1);
                BVH_COUNT(bvh_count_stack = max(bvh_count_stack, sp));
            } else if (sp == 0u) {
                ref = DONE;
            } else {
                BVH_POP(ref);
            }
        }
#ifdef BVH_STREAM
        if (ref == DONE) continue;
#else
        if (ref == DONE) break;
#endif
        uint offset = ref & BVH4_INDEX_MASK;
        uint count = ref >> BVH4_COUNT_SHIFT;
        BVH_COUNT(bvh_count_leaves += 1u; bvh_count_tris += count);
        for (uint k = 0u; k < count;) {
            uint i = offset + k;
            uvec4 ta = texelFetch(bvh_tri_pos, int(3u * i));
            uvec4 tb = texelFetch(bvh_tri_pos, int(3u * i + 1u));
            uvec4 tc = texelFetch(bvh_tri_pos, int(3u * i + 2u));
            uvec3 td = uvec3(ta.w, tb.w, tc.w);
            vec3 a = uintBitsToFloat(ta.xyz);
            vec3 ac = uintBitsToFloat(tc.xyz) - a;
            float t;
            vec2 uv;
            if (bvh_tri_intersect(a, uintBitsToFloat(tb.xyz) - a, ac, o, d, tmin, hit.t, t, uv)) {
                hit.t = t;
                hit.prim = i;
                hit.bary = uv;
            }
            bool quad = any(notEqual(td, ta.xyz));
            if (quad && bvh_tri_intersect(a, ac, uintBitsToFloat(td) - a, o, d, tmin, hit.t, t, uv)) {
                hit.t = t;
                hit.prim = i + 1u;
                hit.bary = uv;
            }
            k += quad ? 2u : 1u;
        }
#ifdef BVH_STREAM
        if (any_hit && hit.prim != DONE) {
            ref = DONE;
            continue;
        }
#else
        if (any_hit && hit.prim != 0xFFFFFFFFu) return true;
#endif
        if (sp == 0u) {
            ref = DONE;
        } else {
            BVH_POP(ref);
        }
    }
#ifndef BVH_STREAM
    return hit.prim != 0xFFFFFFFFu;
#endif
}

#endif  // KERNEL_GPU

// The interface of trace_rayquery.glsl, on either kernel's bvh_trace.
#ifndef BVH_STREAM
bool trace_closest(vec3 o, vec3 d, float tmin, float tmax, out Hit hit) {
    return bvh_trace(o, d, tmin, tmax, false, hit);
}

bool trace_any(vec3 o, vec3 d, float tmin, float tmax) {
    Hit h;
    return bvh_trace(o, d, tmin, tmax, true, h);
}
#endif

#endif
