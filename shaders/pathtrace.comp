#version 460
// The render entry: one invocation per pixel runs this batch's samples and
// writes the pixel's batch moments (GpuPixelAccum). The host merges batches.
// Compiled twice per traversal (CMakeLists.txt): the default module, and with
// VKMECH_DIRECT_GLOSSY defined the variant for `render --extra-output
// direct_glossy` (docs/descriptor.md §3.4), which also writes into floats
// 21..23 of bucket_rgb the RGB of `direct` events whose end vertex is glossy.
// The #ifdef keeps that work out of the default module. With
// VKMECH_COUNTERS (software BVH only; `bench render --profile --counters`)
// it also adds the traversal's work of each invocation to BINDING_COUNTERS:
// traces, interior nodes, leaves, triangles tested, and the deepest stack.
// With VKMECH_DIRECT_TALLY (the GPU kernel's software-BVH module for
// VKMECH_GPU_TALLY=direct, docs/gpu.md) the bucket events go straight into
// the pixel's sums, and a batch with a non-finite sample is traced again.
#extension GL_GOOGLE_include_directive : require
#ifdef KERNEL_GPU
#extension GL_EXT_control_flow_attributes : require
#endif
#include "shared/types.h"
#include "shared/bindings.h"

layout(local_size_x = 8, local_size_y = 8) in;

#include "scene_data.glsl"
#include "traversal.glsl"
#include "rng.glsl"
#include "frame.glsl"
#include "camera.glsl"
#include "features.glsl"
#include "bsdf.glsl"
#include "mechanism.glsl"

layout(std430, set = 0, binding = BINDING_ACCUM) writeonly buffer Accum { GpuPixelAccum accum[]; };
// The next pixel slot to claim (params.claimed_pixels: claimed pixels), zeroed before each batch.
layout(std430, set = 0, binding = BINDING_WORK) buffer Work { uint next_slot; };
#ifdef VKMECH_COUNTERS
#extension GL_ARB_shader_clock : require
layout(std430, set = 0, binding = BINDING_COUNTERS) buffer Counters { uint counters[COUNTER_CLOCK + 2u * PHASE_COUNT]; };
// Adds v to counters[k]; true when the 32-bit total wrapped.
bool counter_add(uint k, uint v) {
    uint before = atomicAdd(counters[k], v);
    return before + v < before;
}
// This invocation's clock ticks per phase (shared/types.h), 64-bit as (low, high).
uvec2 g_clock[PHASE_COUNT];
uint g_clock_backwards = 0u;  // intervals whose end read an earlier clock than their start
// Adds the ticks since `since` (clock2x32ARB, the subgroup's clock) to phase p.
// The subgroup clock is not promised to be monotonic: on lavapipe it is the CPU's
// time-stamp counter, and a thread the OS moves to another core can read an earlier
// value there. Such an interval is counted and left out, not added as 2^64 - x.
void clock_add(uint p, uvec2 since) {
    uvec2 now = clock2x32ARB();
    uint borrow, carry;
    uint lo = usubBorrow(now.x, since.x, borrow);
    uint hi = now.y - since.y - borrow;
    if (hi >= 0x80000000u) {
        g_clock_backwards += 1u;
        return;
    }
    g_clock[p].x = uaddCarry(g_clock[p].x, lo, carry);
    g_clock[p].y += hi + carry;
}
#define CLOCK_START(v) uvec2 v = clock2x32ARB()
#define CLOCK_ADD(p, v) clock_add(p, v)
// Leaves path_sample's loop: the path has ended (busy until here). A block, not
// do { } while (false), whose own loop the `break` would leave instead.
#define PATH_BREAK              \
    {                           \
        CLOCK_ADD(PHASE_BUSY, c_busy); \
        break;                  \
    }
#else
#define CLOCK_START(v)
#define CLOCK_ADD(p, v)
#define PATH_BREAK break
#endif

const float PI = 3.14159265358979;

// Provisional estimator (foundation issue): emission seen directly plus one
// NEE bounce off a Lambertian stand-in for every material. The full docs/descriptor.md §1
// estimator replaces it.
vec3 preview_radiance(inout Rng rng, vec3 o, vec3 d, vec2 t_range) {
    Hit h;
    if (!trace_closest(o, d, t_range.x, t_range.y, h)) return vec3(0.0);
    SurfaceHit s = surface_hit(h.prim, h.bary);
#ifdef KERNEL_GPU
    surface_to_world(s, h.inst);
#endif
    vec3 L = vec3(0.0);
    bool front = dot(s.ng, d) < 0.0;
    if (s.emitter != 0u && front) L += emitter_radiance(s.emitter - 1u) * emission_scale(s.material, s.uv);
    if (params.light_triangle_count == 0u) return L;
    vec3 ng = front ? s.ng : -s.ng;
    vec3 ns = dot(s.ns, ng) < 0.0 ? -s.ns : s.ns;
    GpuMaterial m = material_at(s.material);
    vec3 albedo = (material_flags(m.header.x) & VKM_MATF_ALBEDO) != 0u ? m.reflectance.rgb : vec3(0.5);
    vec3 lu = vec3(rng_next(rng), rng_next(rng), rng_next(rng));
    uint li = select_light_triangle(lu.x);
    if (light_is_infinite(li)) return L;  // the preview samples emissive triangles only
    LightSample ls = sample_light_triangle(li, lu);
    vec3 to_light = ls.p - s.p;
    float dist2 = dot(to_light, to_light);
    float dist = sqrt(dist2);
    vec3 wi = to_light / dist;
    float cos_s = dot(ns, wi);
    float cos_l = -dot(ls.n, wi);
    if (cos_s <= 0.0 || cos_l <= 0.0 || dot(ng, wi) <= 0.0) return L;
    vec3 po = offset_ray_origin(s.p, ng, s.scale);
    vec3 pl = offset_ray_origin(ls.p, ls.n, ls.scale);
    vec3 seg = pl - po;
    float seg_len = length(seg);
    if (trace_any(po, seg / seg_len, 0.0, seg_len)) return L;
    L += albedo / PI * ls.radiance * cos_s * cos_l / (dist2 * ls.pdf_area);
    return L;
}


// Specialization: estimator mode (docs/descriptor.md §1), EST_* (shared/types.h).
layout(constant_id = SPEC_ESTIMATOR) const uint ESTIMATOR = 0u;
// Specialization: the event-recording debug mode (compiled out otherwise).
layout(constant_id = SPEC_DEBUG_EVENTS) const bool DEBUG_EVENTS = false;
// Specialization: docs/descriptor.md §2's end-vertex reading: false = the last non-delta
// vertex (default), true = the literal last surface vertex.
layout(constant_id = SPEC_END_VERTEX_LITERAL) const bool END_VERTEX_LITERAL = false;
// render --pixel-bounds: the film is a window of the full film (GpuParams::window_x0...).
layout(constant_id = SPEC_WINDOW) const bool WINDOW = false;
// render --taxonomy (docs/lpe.md): each contribution event's tally slot is the class of a user
// taxonomy's DFA, whose state the path carries (after the camera and each vertex), instead of the
// built-in cascade's bucket. Off, none of this is compiled in.
layout(constant_id = SPEC_TAXONOMY) const bool TAXONOMY = false;
layout(std430, set = 0, binding = BINDING_TAXONOMY) readonly buffer Taxonomy { uint tax[]; };
uint tax_step(uint state, uint kind, uint label) {
    return tax[TAX_HEADER_WORDS + state * tax[0] + kind * tax[1] + label];
}
// The class of an event that reaches an emitter of `kind` (TAX_KIND_LIGHT, _BACKGROUND) from `state`.
uint tax_class(uint state, uint kind, uint label) { return tax[tax[3] + tax_step(state, kind, label)]; }
uint tax_material_label(uint material) { return tax[tax[4] + material]; }
uint tax_emitter_label(uint emitter) { return tax[tax[5] + emitter]; }
// A surface vertex's event: reflection or transmission (wi on the other side of the shading
// normal from wo), with the lobe class sampled there (or NEE's lobe).
uint tax_vertex(uint state, uint lobe, bool transmitted, uint material) {
    return tax_step(state, (transmitted ? TAX_KIND_TRANSMIT : TAX_KIND_REFLECT) + lobe, tax_material_label(material));
}

// Adaptive rendering (docs/descriptor.md §6): n(p) per pixel; a pixel takes only the samples
// of this batch whose index is below n(p), so n(p) samples of a seed are
// exactly the first n(p) frames of that seed's sample stream. After the P
// counts the buffer holds the pixels sorted by n(p), largest first: a batch
// starting at sample `first` is dispatched over the prefix of pixels that
// still need samples only (params.active_pixels of them), so finished pixels
// cost no invocations.
layout(std430, set = 0, binding = BINDING_SAMPLE_COUNTS) readonly buffer SampleCounts { uint sample_counts[]; };
layout(std430, set = 0, binding = BINDING_DEBUG) buffer DebugEvents {
    uint debug_count;
    uint debug_pad0, debug_pad1, debug_pad2;
    GpuDebugEvent debug_events[];
};
bool g_debug_pixel = false;  // this invocation's pixel is the one recorded
uint g_sample_index = 0u;

// Per-sample tallies of the descriptor (docs/descriptor.md §3), discarded with the sample
// if it turns out non-finite.
struct Tally {
    vec3 L;
    vec3 bucket[BUCKET_COUNT];  // linear RGB of each bucket's events
    float glossy;       // energy of events whose V1..Vn has a glossy lobe
    float depth_sum;    // sum of energy * n over events with n >= 1
    float depth_w;      // sum of energy over events with n >= 1
#ifdef VKMECH_DIRECT_GLOSSY
    vec3 direct_glossy;  // RGB of `direct` events whose end vertex is glossy (l = G)
#endif
};

#ifdef KERNEL_GPU
// Specialization (GPU kernel; VKMECH_GPU_TALLY=shared, docs/gpu.md): the seven RGB
// bucket sums of the sample and of the pixel live in shared memory, each
// invocation its own 21-float slices indexed at run time, instead of two
// register arrays live through the whole path (42 floats). The adds happen in
// the same order, so the images are bit-identical either way.
layout(constant_id = SPEC_SHARED_TALLY) const bool SHARED_TALLY = false;
const uint TALLY_FLOATS = 3u * BUCKET_COUNT;
shared float s_sample_tally[SHARED_TALLY ? 64u * TALLY_FLOATS : 1u];
shared float s_pixel_tally[SHARED_TALLY ? 64u * TALLY_FLOATS : 1u];
uint tally_base() { return gl_LocalInvocationIndex * TALLY_FLOATS; }  // 21 is odd: no bank conflicts
#endif
#ifdef VKMECH_DIRECT_TALLY
// The direct tally (GPU kernel, VKMECH_GPU_TALLY=direct, docs/gpu.md; a module of its own, so the
// default modules are unchanged): Tally::bucket holds the pixel's sums for the whole batch and each
// event is added to them at once, 21 floats live through the path instead of 42. A non-finite
// sample's events are then in the sums too; render_slot traces such a batch again (rare), and
// g_tally_off keeps a sample's events out of the sums while it finds out whether the sample counts.
bool g_tally_off = false;
#endif

// tax_cls: the event's class under a user taxonomy (read only when TAXONOMY).
void add_event(inout Tally t, vec3 contrib, uint n, uint end_lobe, bool delta_before, bool glossy_before,
               uint tax_cls) {
    t.L += contrib;
    if (!FEATURE_CAPTURE) return;
    float e = luminance(contrib);
    uint b = TAXONOMY ? tax_cls : classify_event(n, end_lobe, delta_before);
#ifdef KERNEL_GPU
    if (SHARED_TALLY) {
        uint i = tally_base() + 3u * b;
        s_sample_tally[i] += contrib.r;
        s_sample_tally[i + 1u] += contrib.g;
        s_sample_tally[i + 2u] += contrib.b;
    } else {
        // Constant indices: a GPU keeps the tally in registers, where an index
        // known only at run time puts the whole array in local memory.
#ifdef VKMECH_DIRECT_TALLY
        if (!g_tally_off)
#endif
        [[unroll]] for (uint k = 0u; k < BUCKET_COUNT; ++k) t.bucket[k] += k == b ? contrib : vec3(0.0);
    }
#else
    t.bucket[b] += contrib;
#endif
#ifdef VKMECH_DIRECT_GLOSSY
    if (b == BUCKET_DIRECT && end_lobe == LOBE_G) t.direct_glossy += contrib;
#endif
    if (DEBUG_EVENTS && g_debug_pixel) {
        uint slot = atomicAdd(debug_count, 1u);
        if (slot < params.debug_capacity) {
            debug_events[slot].label = uvec4(n, end_lobe, delta_before ? 1u : 0u, b);
            debug_events[slot].energy = vec4(e, glossy_before ? 1.0 : 0.0, float(g_sample_index), 0.0);
        }
    }
    if (glossy_before || end_lobe == LOBE_G) t.glossy += e;
    if (n >= 1u) {
        t.depth_sum += e * float(n);
        t.depth_w += e;
    }
}

// Mitsuba's blendbsdf (docs/descriptor.md §2): the material a hit sees is one of the
// blend's components, the second with probability `weight` and the first otherwise; a
// textured weight is the texture at uv (its luminance, which the loader stores in every
// channel). NEE, MIS and the sampled bounce at the vertex all query that one component, so
// each is unbiased for the blend, (1 - w) f1 + w f2, and the event's label follows the
// component's lobes. Nested blends are resolved with the same uniform number, rescaled; a
// weight of 0 or 1 draws none. A blend's twosided flag and its normal or bump map pass to a
// component that has none of its own (the loader refuses two).
GpuMaterial blend_resolve(GpuMaterial m, vec2 uv, inout Rng rng) {
    float u = -1.0;
    for (uint level = 0u; level < BLEND_MAX_DEPTH && m.header.x == MAT_BLEND; ++level) {
        float w = m.reflectance.x;
        uint t_weight = m.header.z & MAT_TEX_MASK;
        if (FEATURE_TEXTURES && t_weight != 0u) w = texture_lookup(t_weight - 1u, uv).x;  // luminance in every channel
        w = clamp(w, 0.0, 1.0);
        bool second = w >= 1.0;
        if (w > 0.0 && w < 1.0) {
            if (u < 0.0) u = rng_next(rng);
            second = u < w;
            u = second ? u / w : (u - w) / (1.0 - w);
        }
        GpuMaterial c = material_at(second ? m.header.w >> 16 : m.header.w & 0xFFFFu);
        c.header.y |= m.header.y & 1u;
        if (FEATURE_TEXTURES && c.frame_tex.x == 0u) {
            c.frame_tex.x = m.frame_tex.x;
            c.frame_tex.y = m.frame_tex.y;
            c.frame_tex.w = m.frame_tex.w;
        }
        m = c;
    }
    return m;
}

// principled's textured float parameters besides metallic and roughness (GpuMaterial::param_tex):
// each textured one is its texture at uv (the luminance, in every channel), as Mitsuba 3 reads
// a float texture, not the constant (which holds the texture's mean).
float param_at(uint slot, vec2 uv, float constant) { return slot == 0u ? constant : texture_lookup(slot - 1u, uv).x; }
void principled_textured_params(inout GpuMaterial m, vec2 uv) {
    uvec4 t = m.param_tex;
    if (all(equal(t, uvec4(0u)))) return;
    m.model0.w = param_at(t.x & MAT_TEX_MASK, uv, m.model0.w);   // spec_tint
    m.model1.x = param_at(t.x >> MAT_TEX_SHIFT, uv, m.model1.x);  // anisotropic
    m.model1.y = param_at(t.y & MAT_TEX_MASK, uv, m.model1.y);   // sheen
    m.model1.z = param_at(t.y >> MAT_TEX_SHIFT, uv, m.model1.z);  // sheen_tint
    m.model1.w = param_at(t.z & MAT_TEX_MASK, uv, m.model1.w);   // clearcoat
    m.model2.x = param_at(t.z >> MAT_TEX_SHIFT, uv, m.model2.x);  // clearcoat_gloss
    m.model2.y = param_at(t.w & MAT_TEX_MASK, uv, m.model2.y);   // spec_trans
}

// The shading normal a normal map gives at s (GpuMaterial::frame_tex): the map's
// tangent-space normal n (texel x 2 - 1, x and y times the scale) in the frame
// t = dp/du made orthogonal to the shading normal ns, b = ns x t, ns (Mitsuba's
// normalmap). With uv_handed (glTF), b is turned against dp/dv where the uv layout
// is mirrored: MikkTSpace's bitangent sign, which glTF's stored tangents carry in
// w, taken per triangle (+y of the map is -v, glTF's uv origin being the image's
// top left). Where the mesh has the file's tangents, surface_hit made dp/du the tangent
// and dp/dv the bitangent's opposite, so t and b are the file's. ns unchanged where the
// uvs give no tangent.
vec3 normal_mapped(SurfaceHit s, uint slot, float scale, bool uv_handed) {
    vec3 t = s.dpdu - s.ns * dot(s.ns, s.dpdu);
    float tl = length(t);
    if (!(tl > 0.0)) return s.ns;
    t /= tl;
    vec3 b = cross(s.ns, t);
    if (uv_handed && dot(b, s.dpdv) > 0.0) b = -b;
    vec3 n = texture_lookup(slot - 1u, s.uv) * 2.0 - 1.0;
    vec3 m = t * (n.x * scale) + b * (n.y * scale) + s.ns * n.z;
    float ml = length(m);
    return ml > 0.0 ? m / ml : s.ns;
}

// The shading normal a bump map gives at s (Mitsuba 3's bumpmap): the height h (the texture's
// luminance times scale) displaces the surface along ns, so dp/du' = dp/du + ns (dh/du -
// ns . dp/du) and likewise for v, and ns' = dp/du' x dp/dv', turned to the side of ng. A
// constant height gives ns back; ns unchanged where the uvs give no derivatives.
vec3 bump_mapped(SurfaceHit s, uint slot, float scale) {
    vec2 g = scale * texture_luminance_gradient(slot - 1u, s.uv);
    vec3 du = s.dpdu + s.ns * (g.x - dot(s.ns, s.dpdu));
    vec3 dv = s.dpdv + s.ns * (g.y - dot(s.ns, s.dpdv));
    vec3 m = cross(du, dv);
    float ml = length(m);
    if (!(ml > 0.0)) return s.ns;
    m /= ml;
    return dot(m, s.ng) < 0.0 ? -m : m;
}

// Whether the segment from o along unit d is blocked before tmax (NEE's shadow ray).
bool shadow_blocked(vec3 o, vec3 d, float tmax) {
#ifdef VKMECH_COUNTERS
    CLOCK_START(c_shadow);
    bool occluded = trace_any(o, d, 0.0, tmax);
    CLOCK_ADD(PHASE_SHADOW, c_shadow);
    return occluded;
#else
    return trace_any(o, d, 0.0, tmax);
#endif
}

// The state of the vertex a segment left from (V(k-1)), for labelling and
// weighting what the segment's end emits.
struct PrevVertex {
    uint lobe;           // the lobe sampled there
    float pdf;           // its solid-angle pdf (non-delta)
    bool mis;            // its BSDF-sampled emitter hits use MIS
    bool delta_before;   // any of V1..V(k-2) sampled a delta lobe
    bool glossy_before;  // any of V1..V(k-2) sampled a glossy lobe
    uint last_nondelta;  // lobe of the last non-delta vertex among V1..V(k-2)
};

// Emission `contrib` (throughput x radiance) seen by segment k, whose NEE
// density (solid angle, selection included) is p_light: counted from the camera
// (k = 1) and after a delta lobe; after a non-delta lobe MIS-weighted in the
// MIS modes, else left to NEE (docs/descriptor.md §1).
// (tax_cls: the event's class under a user taxonomy.)
void emission_seen(inout Tally tally, vec3 contrib, uint k, float p_light, PrevVertex pv, uint tax_cls) {
    if (k == 1u) {
        add_event(tally, contrib, 0u, LOBE_NONE, false, false, tax_cls);
    } else if (pv.lobe == LOBE_S) {
        add_event(tally, contrib, k - 1u, bsdf_hit_end_lobe(END_VERTEX_LITERAL, pv.lobe, pv.last_nondelta),
                  bsdf_hit_delta(END_VERTEX_LITERAL, pv.lobe, pv.last_nondelta, pv.delta_before), pv.glossy_before,
                  tax_cls);
    } else if (pv.mis && pv.pdf > 0.0) {
        float w = power_heuristic(pv.pdf, p_light);
        add_event(tally, contrib * w, k - 1u, pv.lobe, pv.delta_before, pv.glossy_before, tax_cls);
    }
}

// The docs/descriptor.md §1 estimator: unidirectional path tracing with NEE at every
// non-delta vertex, BSDF-sampled emitter hits accepted only from the camera
// or after a delta lobe (or MIS-weighted in the MIS modes), Russian roulette
// from depth rr_depth, at most max_depth segments. The camera ray is traced over t_range
// (its clip planes, camera_ray), every later segment from its origin on.
void path_sample(inout Rng rng, vec3 o, vec3 d, vec2 t_range, inout Tally tally) {
    uint max_depth = params.max_depth;
    uint rr_depth = params.rr_depth;
    vec3 throughput = vec3(1.0);
    bool delta_before = false;   // any of V1..V(k-1) sampled a delta lobe
    bool glossy_before = false;  // any of V1..V(k-1) sampled a glossy lobe
    PrevVertex pv = PrevVertex(LOBE_NONE, 0.0, false, false, false, LOBE_NONE);
    uint last_nondelta = LOBE_NONE;  // lobe of the last non-delta vertex among V1..V(k-1)
    float eta_path = 1.0;  // product of the relative IORs crossed (docs/descriptor.md §1 Russian roulette)
    uint tax_state = TAXONOMY ? tax[2] : 0u;  // the taxonomy's state after the camera and V1..V(k-1)
    CLOCK_START(c_busy);
    for (uint k = 1u; k <= max_depth; ++k) {
        Hit h;
#ifdef VKMECH_COUNTERS
        CLOCK_START(c_trace);
        bool found = trace_closest(o, d, t_range.x, t_range.y, h);
        CLOCK_ADD(k == 1u ? PHASE_PRIMARY : PHASE_BOUNCE, c_trace);
#else
        bool found = trace_closest(o, d, t_range.x, t_range.y, h);
#endif
        t_range = vec2(0.0, RAY_TMAX);
        if (!found) {
            // ---- the segment escapes: the environment's emission ----
            if (FEATURE_ENVIRONMENT) {
                GpuEnvironment env = environment_at();
                if (env.map.x != ENV_NONE)
                    emission_seen(tally, throughput * env_eval(env, d), k, env.radiance.w * env_pdf(env, d), pv,
                                  TAXONOMY ? tax_class(tax_state, TAX_KIND_BACKGROUND, 0u) : 0u);
            }
            PATH_BREAK;
        }
        SurfaceHit s = surface_hit(h.prim, h.bary);
#ifdef KERNEL_GPU
        surface_to_world(s, h.inst);
#endif

        // ---- emission seen by this segment ----
        if (s.emitter != 0u && dot(s.ng, d) < 0.0) {
            GpuEmitter em = emitter_at(s.emitter - 1u);
            float cos_l = -dot(s.ng, d);
            float dist2 = h.t * h.t;
            // NEE's area pdf of this point: the emitter's selection probability
            // over its area (uniform or power selection), in solid angle.
            float p_light = uintBitsToFloat(em.info.w) * dist2 / max(cos_l, 1e-12);
            emission_seen(tally, throughput * (em.radiance.rgb * emission_scale(s.material, s.uv)), k, p_light, pv,
                          TAXONOMY ? tax_class(tax_state, TAX_KIND_LIGHT, tax_emitter_label(s.emitter - 1u)) : 0u);
        }
        if (k >= max_depth) PATH_BREAK;  // no segment left for NEE or a bounce

        GpuMaterial m = material_at(s.material);
        if (FEATURE_BLEND) m = blend_resolve(m, s.uv, rng);
        if (FEATURE_TEXTURES && m.frame_tex.x != 0u) {
            uint normal_slot = m.frame_tex.x & MAT_TEX_MASK;
            float scale = uintBitsToFloat(m.frame_tex.y);
            s.ns = normal_slot != 0u ? normal_mapped(s, normal_slot, scale, m.frame_tex.w != 0u)
                                     : bump_mapped(s, m.frame_tex.x >> MAT_TEX_SHIFT, scale);
        }
        Frame3 fr = frame_from_normal(s.ns);
        vec3 wo_world = -d;
        vec3 wo = to_local(fr, wo_world);
        // Shading-normal consistency: wo must lie on the same side of both normals.
        if (wo.z * dot(wo_world, s.ng) <= 0.0) PATH_BREAK;
        vec3 albedo = m.reflectance.rgb;
        if (FEATURE_TEXTURES) {
            uint t_refl = m.header.z & MAT_TEX_MASK;
            uint t_spec = m.header.z >> MAT_TEX_SHIFT;
            uint t_trans = m.header.y >> MAT_TEX_SHIFT;
            if (t_refl != 0u) albedo = texture_lookup(t_refl - 1u, s.uv);
            // The constants hold the textures' means (sampling weights use
            // them); the lookup replaces the colour the BSDF evaluates with.
            if (t_spec != 0u) m.specular_reflectance = vec4(texture_lookup(t_spec - 1u, s.uv), m.specular_reflectance.w);
            if (t_trans != 0u)
                m.specular_transmittance = vec4(texture_lookup(t_trans - 1u, s.uv), m.specular_transmittance.w);
            uint t_alpha = m.frame_tex.z;  // the rough models' alpha_u (low) and alpha_v (high)
            if (t_alpha != 0u) {
                uint t_u = t_alpha & MAT_TEX_MASK, t_v = t_alpha >> MAT_TEX_SHIFT;
                // As the loader's constants: alpha 0 would be a delta lobe in disguise.
                if (t_u != 0u) m.reflectance.w = max(luminance(texture_lookup(t_u - 1u, s.uv)), 1e-4);
                if (t_v != 0u) m.specular_reflectance.w = max(luminance(texture_lookup(t_v - 1u, s.uv)), 1e-4);
            }
            uint t_param = m.header.w >> MAT_TEX_SHIFT;  // principled's metallic (B) and roughness (G)
            if (t_param != 0u) {
                vec3 mr = texture_lookup(t_param - 1u, s.uv);
                m.model0.x = mr.z;
                m.model0.y = mr.y;
            }
            if (FEATURE_PRINCIPLED && m.header.x == MAT_PRINCIPLED) principled_textured_params(m, s.uv);
        }

        // ---- next-event estimation (docs/descriptor.md §1: at every non-delta vertex) ----
        uint nee_lobe = bsdf_nee_lobe(m);
        bool vertex_mis = false;
        if (nee_lobe != LOBE_NONE) {
            if (ESTIMATOR == EST_MIS) {
                vertex_mis = true;
            } else if (ESTIMATOR == EST_MIS_RESTRICTED) {
                uint b = classify_event(k, nee_lobe, delta_before);
                vertex_mis = b == BUCKET_GLOSSY || b == BUCKET_DELTA_MEDIATED;
            }
        }
        if (nee_lobe != LOBE_NONE && params.light_triangle_count > 0u) {
            CLOCK_START(c_nee);
            vec3 lu = vec3(rng_next(rng), rng_next(rng), rng_next(rng));
            uint li = select_light_triangle(lu.x);
            if (light_is_infinite(li)) {
                // An emitter at infinity: a direction, and a shadow ray to the scene's end.
                GpuLightTriangle lt = light_tri_at(li);
                InfiniteSample is = sample_infinite(lt.info.y, lt.cdf.z, vec2(lu.y, lu.z));
                vec3 wi = to_local(fr, is.wi);
                if (is.pdf > 0.0 && wi.z * dot(is.wi, s.ng) > 0.0) {
                    vec3 f = bsdf_eval(m, albedo, wo, wi);
                    if ((f.x > 0.0 || f.y > 0.0 || f.z > 0.0) &&
                        !shadow_blocked(offset_ray_origin(s.p, dot(is.wi, s.ng) > 0.0 ? s.ng : -s.ng, s.scale), is.wi,
                                        RAY_TMAX)) {
                        float w = 1.0;
                        if (vertex_mis && !is.delta) w = power_heuristic(is.pdf, bsdf_pdf(m, albedo, wo, wi));
                        // An environment is B; a directional light is L (docs/lpe.md), without a label.
                        uint cls = TAXONOMY ? tax_class(tax_vertex(tax_state, nee_lobe, wi.z * wo.z < 0.0, s.material),
                                                        lt.info.y == 0u ? TAX_KIND_BACKGROUND : TAX_KIND_LIGHT, 0u)
                                            : 0u;
                        add_event(tally, throughput * f * is.radiance * (w / is.pdf), k, nee_lobe, delta_before,
                                  glossy_before, cls);
                    }
                }
                CLOCK_ADD(PHASE_NEE, c_nee);
            } else {
                LightSample ls = sample_light_triangle(li, lu);
                vec3 to_light = ls.p - s.p;
                float dist2 = dot(to_light, to_light);
                float dist = sqrt(dist2);
                vec3 wi_world = to_light / dist;
                float cos_l = -dot(ls.n, wi_world);
                vec3 wi = to_local(fr, wi_world);
                if (cos_l > 0.0 && dist2 > 0.0 && wi.z * dot(wi_world, s.ng) > 0.0) {
                    vec3 f = bsdf_eval(m, albedo, wo, wi);
                    if (f.x > 0.0 || f.y > 0.0 || f.z > 0.0) {
                        vec3 ng_side = dot(wi_world, s.ng) > 0.0 ? s.ng : -s.ng;
                        vec3 po = offset_ray_origin(s.p, ng_side, s.scale);
                        vec3 pl = offset_ray_origin(ls.p, ls.n, ls.scale);
                        vec3 seg = pl - po;
                        float seg_len = length(seg);
                        if (!shadow_blocked(po, seg / seg_len, seg_len)) {
                            float p_light = ls.pdf_area * dist2 / cos_l;
                            float w = 1.0;
                            if (vertex_mis) w = power_heuristic(p_light, bsdf_pdf(m, albedo, wo, wi));
                            uint cls = TAXONOMY ? tax_class(tax_vertex(tax_state, nee_lobe, wi.z * wo.z < 0.0,
                                                                       s.material),
                                                            TAX_KIND_LIGHT, tax_emitter_label(light_tri_at(li).info.y))
                                                : 0u;
                            add_event(tally, throughput * f * ls.radiance * (w / p_light), k, nee_lobe, delta_before,
                                      glossy_before, cls);
                        }
                    }
                }
                CLOCK_ADD(PHASE_NEE, c_nee);
            }
        } else {
            // Keep the dimension count independent of the branch taken.
            rng.dim += 3u;
        }

        // ---- BSDF sampling ----
        float u_lobe = rng_next(rng);
        vec2 u2 = rng_next2(rng);
        BsdfSample bs = bsdf_sample(m, albedo, wo, u_lobe, u2);
        if (!bs.ok) PATH_BREAK;
        vec3 wi_world = to_world(fr, bs.wi);
        if (bs.wi.z * dot(wi_world, s.ng) <= 0.0) PATH_BREAK;
        throughput *= bs.weight;

        pv = PrevVertex(bs.lobe, bs.pdf, vertex_mis && bs.lobe != LOBE_S, delta_before, glossy_before, last_nondelta);
        if (TAXONOMY) tax_state = tax_vertex(tax_state, bs.lobe, bs.wi.z * wo.z < 0.0, s.material);
        if (bs.lobe == LOBE_S) delta_before = true;
        else last_nondelta = bs.lobe;
        if (bs.lobe == LOBE_G) glossy_before = true;
        eta_path *= bs.eta;

        // ---- Russian roulette (docs/descriptor.md §1: from depth rr_depth) ----
        // Survival as Mitsuba 3's path integrator: max throughput times eta^2,
        // so a path inside glass is not killed for the 1/eta^2 its radiance
        // scaling put into the throughput.
        float u_rr = rng_next(rng);
        if (k >= rr_depth) {
            float q = min(max(throughput.x, max(throughput.y, throughput.z)) * eta_path * eta_path, 0.95);
            if (!(u_rr < q)) PATH_BREAK;
            throughput /= q;
        }
        if (!(max(throughput.x, max(throughput.y, throughput.z)) > 0.0)) PATH_BREAK;

        vec3 ng_side = dot(wi_world, s.ng) > 0.0 ? s.ng : -s.ng;
        o = offset_ray_origin(s.p, ng_side, s.scale);
        d = wi_world;
    }
#ifdef VKMECH_COUNTERS
    if (max_depth == 0u) CLOCK_ADD(PHASE_BUSY, c_busy);  // the loop did not run: no PATH_BREAK
#endif
}

// (a * b) mod n for n <= 2^24 without 64-bit integers: b a byte at a time
// (every partial product and shifted remainder stays below 2^32).
uint mulmod(uint a, uint b, uint n) {
    a %= n;
    uint r = 0u;
    for (int shift = 24; shift >= 0; shift -= 8) {
        r = ((r << 8u) % n + (a * ((b >> uint(shift)) & 0xFFu)) % n) % n;
    }
    return r;
}

// The film's 8 x 8 tiles per row.
uint film_tiles_x() { return (params.film_width + 7u) / 8u; }

// One sample's camera ray, shared by render_slot and the direct tally's redo: the sample's
// stream (pixel `stream`, sample `index`), the box filter's jitter inside the pixel and the lens
// sample, in that order. Declares rng, o, d and t_range in the enclosing scope.
#define SAMPLE_CAMERA_RAY(index)                                   \
    Rng rng = rng_init(params.seed, stream, index);                \
    vec2 jitter = rng_next2(rng);                                  \
    vec2 lens = rng_next2(rng);                                    \
    vec2 film_uv = (vec2(full_px) + jitter) / vec2(full_size);     \
    vec3 o, d;                                                     \
    vec2 t_range;                                                  \
    camera_ray(film_uv, lens, o, d, t_range)
// A sample that would make the batch's running sums non-finite (docs/descriptor.md §3): counted, never added.
#define SAMPLE_NOT_FINITE(rgb_next, lum, depth_next)                                                        \
    (any(isnan(rgb_next)) || any(isinf(rgb_next)) || isnan(lum) || isinf(lum) || isnan(depth_next) || \
     isinf(depth_next))

#ifdef VKMECH_DIRECT_TALLY
#ifndef KERNEL_GPU
#error "VKMECH_DIRECT_TALLY is the GPU kernel's: the CPU kernel's add_event has no g_tally_off"
#endif
// The direct tally's redo of a batch with a non-finite sample: the buckets from zero, and every sample
// that counted traced once more into them (the streams are deterministic: the same paths). bad_mask
// holds the first pass's decisions for the batch's samples 0..63, so the redo does not decide again;
// only where a sample beyond the 64th was non-finite (bad_beyond) does it find out again, tracing each
// sample first with the tally off and applying the first pass's test to the same running sums.
void redo_direct_tally(inout Tally t, uint stream, uint first, uint count, uvec2 full_px, uvec2 full_size,
                       uvec2 bad_mask, bool bad_beyond) {
    g_debug_pixel = false;
    for (uint b = 0u; b < BUCKET_COUNT; ++b) t.bucket[b] = vec3(0.0);
    vec3 rgb_sum = vec3(0.0);
    float depth_sum = 0.0;
    for (uint i = 0u; i < count; ++i) {
        if (!bad_beyond && i < 64u && (bad_mask[i >> 5u] & (1u << (i & 31u))) != 0u) continue;
        for (uint pass = bad_beyond ? 0u : 1u; pass < 2u; ++pass) {
            g_tally_off = pass == 0u;
            g_sample_index = first + i;
            SAMPLE_CAMERA_RAY(first + i);
            t.L = vec3(0.0);
            t.glossy = 0.0;
            t.depth_sum = 0.0;
            t.depth_w = 0.0;
            path_sample(rng, o, d, t_range, t);
            if (pass == 1u) break;
            float lum = luminance(t.L);
            vec3 rgb_next = rgb_sum + t.L;
            float depth_next = depth_sum + t.depth_sum;
            if (SAMPLE_NOT_FINITE(rgb_next, lum, depth_next)) break;  // not counted: its events stay out of the sums
            rgb_sum = rgb_next;
            depth_sum = depth_next;
        }
    }
    g_tally_off = false;
}
#endif

// Renders this batch's samples of the pixel in slot `slot`: the film in 8 x 8
// tiles, tile t = slot / 64 (row-major over the film's tiles) and
// invocation slot % 64 within it; in the adaptive mode the slot-th pixel of
// the active list (sample_counts[width * height + slot]).
void render_slot(uint slot) {
    uint width = params.film_width;
    uint height = params.film_height;
    uvec2 px;
    if (params.per_pixel_counts != 0u) {
        if (slot >= params.active_pixels) return;
        uint p = sample_counts[width * height + slot];
        px = uvec2(p % width, p / width);
    } else {
        uint tile = slot / 64u;
        uint local = slot % 64u;
        px = uvec2(tile % film_tiles_x(), tile / film_tiles_x()) * 8u + uvec2(local % 8u, local / 8u);
    }
    if (px.x >= width || px.y >= height) return;
    uint pixel = px.y * width + px.x;
    uint first = params.first_sample;
    uint count = params.batch_samples;
    if (params.per_pixel_counts != 0u) {
        uint n = sample_counts[pixel];
        count = n > first ? min(count, n - first) : 0u;
    }

    vec3 rgb_sum = vec3(0.0);
    float n_ok = 0.0;
    // Welford in a scaled form (docs/descriptor.md §3.1): luminance is divided by 2^lum_exp,
    // the exponent of the largest |luminance| seen, so mean_s stays in [0, 1]
    // and m2_s in [0, n]: M2 = m2_s * 4^lum_exp neither overflows (radiance
    // 1e30: M2 ~ 1e60) nor underflows (1e-30) in float. Power-of-two scaling
    // is exact, so the result is bit for bit the plain Welford's wherever that
    // one stays in range.
    int lum_exp = -126;
    float mean_s = 0.0;
    float m2_s = 0.0;
    float nonfinite = 0.0;
    vec3 bucket_sum[BUCKET_COUNT];
    for (uint b = 0u; b < BUCKET_COUNT; ++b) bucket_sum[b] = vec3(0.0);
#ifdef KERNEL_GPU
    if (SHARED_TALLY)
        for (uint j = 0u; j < TALLY_FLOATS; ++j) s_pixel_tally[tally_base() + j] = 0.0;
#endif
    float glossy_sum = 0.0;
    float depth_sum = 0.0;
    float depth_w = 0.0;
#ifdef VKMECH_DIRECT_GLOSSY
    vec3 direct_glossy_sum = vec3(0.0);
#endif
    g_debug_pixel = DEBUG_EVENTS && params.debug_capacity > 0u && pixel == params.debug_pixel;
    // The full film's pixel: its camera rays and its random stream (the window's pixel indexes the film).
    uvec2 full_px = px;
    uvec2 full_size = uvec2(width, height);
    if (WINDOW) {
        full_px += uvec2(params.window_x0, params.window_y0);
        full_size = uvec2(params.full_width, params.full_height);
    }
    uint stream = WINDOW ? full_px.y * full_size.x + full_px.x : pixel;
#ifdef VKMECH_DIRECT_TALLY
    Tally t;  // its buckets: the pixel's sums through the batch
    for (uint b = 0u; b < BUCKET_COUNT; ++b) t.bucket[b] = vec3(0.0);
    uvec2 bad_mask = uvec2(0u);  // the batch's non-finite samples among its first 64
    bool bad_beyond = false;     // a non-finite sample beyond them
#endif
    for (uint i = 0u; i < count; ++i) {
        CLOCK_START(c_camera);
        g_sample_index = first + i;
        SAMPLE_CAMERA_RAY(first + i);
#ifndef VKMECH_DIRECT_TALLY
        Tally t;
        t.L = vec3(0.0);
        for (uint b = 0u; b < BUCKET_COUNT; ++b) t.bucket[b] = vec3(0.0);
#else
        t.L = vec3(0.0);
#endif
#ifdef KERNEL_GPU
        if (SHARED_TALLY)
            for (uint j = 0u; j < TALLY_FLOATS; ++j) s_sample_tally[tally_base() + j] = 0.0;
#endif
        t.glossy = 0.0;
        t.depth_sum = 0.0;
        t.depth_w = 0.0;
#ifdef VKMECH_DIRECT_GLOSSY
        t.direct_glossy = vec3(0.0);
#endif
        CLOCK_ADD(PHASE_CAMERA, c_camera);
        if (params.mode == MODE_PATH) {
            CLOCK_START(c_path);
            path_sample(rng, o, d, t_range, t);
            CLOCK_ADD(PHASE_PATH, c_path);
        } else {
            t.L = preview_radiance(rng, o, d, t_range);
        }
        float lum = luminance(t.L);
        // A sample that would overflow the batch sums is as non-finite as
        // one that is already: counted, never added (docs/descriptor.md §3).
        vec3 rgb_next = rgb_sum + t.L;
        float depth_next = depth_sum + t.depth_sum;
        bool bad = SAMPLE_NOT_FINITE(rgb_next, lum, depth_next);
        if (bad) {
            nonfinite += 1.0;
#ifdef VKMECH_DIRECT_TALLY
            if (i < 64u)
                bad_mask[i >> 5u] |= 1u << (i & 31u);
            else
                bad_beyond = true;
#endif
            continue;
        }
        rgb_sum = rgb_next;
        n_ok += 1.0;
        int e;
        frexp(lum, e);
        if (lum != 0.0 && e > lum_exp) {  // a new largest magnitude: rescale
            mean_s = ldexp(mean_s, lum_exp - e);
            m2_s = ldexp(m2_s, 2 * (lum_exp - e));
            lum_exp = e;
        }
        float x = ldexp(lum, -lum_exp);
        float delta = x - mean_s;  // Welford within the batch
        mean_s += delta / n_ok;
        m2_s += delta * (x - mean_s);
#if defined(KERNEL_GPU) && !defined(VKMECH_DIRECT_TALLY)
        if (SHARED_TALLY)
            for (uint j = 0u; j < TALLY_FLOATS; ++j) s_pixel_tally[tally_base() + j] += s_sample_tally[tally_base() + j];
        else
#endif
#ifndef VKMECH_DIRECT_TALLY
            for (uint b = 0u; b < BUCKET_COUNT; ++b) bucket_sum[b] += t.bucket[b];
#endif
        glossy_sum += t.glossy;
        depth_sum += t.depth_sum;
        depth_w += t.depth_w;
#ifdef VKMECH_DIRECT_GLOSSY
        direct_glossy_sum += t.direct_glossy;
#endif
    }
#ifdef VKMECH_DIRECT_TALLY
    if (nonfinite > 0.0 && params.mode == MODE_PATH)
        redo_direct_tally(t, stream, first, count, full_px, full_size, bad_mask, bad_beyond);
    for (uint b = 0u; b < BUCKET_COUNT; ++b) bucket_sum[b] = t.bucket[b];
#endif
    GpuPixelAccum a;
    a.rgb = vec4(rgb_sum, n_ok);
    // x: the mean itself (at most the largest sample: finite); y, w: M2 as
    // m2_s * 4^w (host/engine/render/frame.hpp, batch_lum_m2).
    a.lum = vec4(ldexp(mean_s, lum_exp), m2_s, nonfinite, float(lum_exp));
    a.side = vec4(glossy_sum, depth_sum, depth_w, 0.0);
#ifdef KERNEL_GPU
    if (SHARED_TALLY)
        for (uint b = 0u; b < BUCKET_COUNT; ++b) {
            uint i = tally_base() + 3u * b;
            bucket_sum[b] = vec3(s_pixel_tally[i], s_pixel_tally[i + 1u], s_pixel_tally[i + 2u]);
        }
#endif
    // Seven RGB sums packed into six vec4s (GpuPixelAccum::bucket_rgb, float 3b + c).
    a.bucket_rgb[0] = vec4(bucket_sum[0], bucket_sum[1].x);
    a.bucket_rgb[1] = vec4(bucket_sum[1].yz, bucket_sum[2].xy);
    a.bucket_rgb[2] = vec4(bucket_sum[2].z, bucket_sum[3]);
    a.bucket_rgb[3] = vec4(bucket_sum[4], bucket_sum[5].x);
    a.bucket_rgb[4] = vec4(bucket_sum[5].yz, bucket_sum[6].xy);
#ifdef VKMECH_DIRECT_GLOSSY
    a.bucket_rgb[5] = vec4(bucket_sum[6].z, direct_glossy_sum);
#else
    a.bucket_rgb[5] = vec4(bucket_sum[6].z, 0.0, 0.0, 0.0);
#endif
    accum[pixel] = a;
}

void main() {
    // Claimed pixels (params.claimed_pixels, CPU devices): each invocation takes
    // the next slot from a counter until none is left, so the device's
    // threads finish together (lavapipe splits a dispatch's workgroups into
    // one contiguous range per thread up front, and whichever range holds
    // more work would otherwise leave the other threads idle at the end).
    // Tiles: the workgroup with index w renders tile w * stride mod n
    // (params.workgroup_stride, coprime with n: a permutation), an order spread
    // over the image (docs/performance.md, "Balancing lavapipe's threads").
    // One call site: the path tracer is inlined once (the direct tally's module also traces in its redo).
#ifdef VKMECH_COUNTERS
    for (uint p = 0u; p < PHASE_COUNT; ++p) g_clock[p] = uvec2(0u);
#endif
    bool claimed = params.claimed_pixels != 0u;
    uint slot, slots;
    if (claimed) {
        slots = params.per_pixel_counts != 0u ? params.active_pixels : film_tiles_x() * ((params.film_height + 7u) / 8u) * 64u;
        slot = atomicAdd(next_slot, 1u);
    } else {
        uint groups = gl_NumWorkGroups.x * gl_NumWorkGroups.y;
        uint tile = mulmod(gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x, params.workgroup_stride, groups);
        slot = tile * 64u + gl_LocalInvocationIndex;
        slots = slot + 1u;
    }
    while (slot < slots) {
        CLOCK_START(c_slot);
        render_slot(slot);
        CLOCK_ADD(PHASE_SLOT, c_slot);
        slot = claimed ? atomicAdd(next_slot, 1u) : slots;
    }
#ifdef VKMECH_COUNTERS
    // A 32-bit total that wrapped sets COUNTER_WRAPPED (the host refuses the counts).
    bool wrapped = counter_add(COUNTER_RAYS, bvh_count_rays);
    wrapped = counter_add(COUNTER_NODES, bvh_count_nodes) || wrapped;
    wrapped = counter_add(COUNTER_LEAVES, bvh_count_leaves) || wrapped;
    wrapped = counter_add(COUNTER_TRIANGLES, bvh_count_tris) || wrapped;
    atomicMax(counters[COUNTER_DEEPEST_STACK], bvh_count_stack);
    for (uint p = 0u; p < PHASE_COUNT; ++p) {  // 64-bit sums: the low word's carry goes into the high word
        uint lo = COUNTER_CLOCK + 2u * p;
        uint before = atomicAdd(counters[lo], g_clock[p].x);
        atomicAdd(counters[lo + 1u], g_clock[p].y + (before + g_clock[p].x < before ? 1u : 0u));
    }
    atomicAdd(counters[COUNTER_CLOCK_BACKWARDS], g_clock_backwards);
    if (wrapped) atomicOr(counters[COUNTER_WRAPPED], 1u);
#endif
}
