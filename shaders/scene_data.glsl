// Scene buffers and hit-point reconstruction shared by the render entries.
#ifndef VKMECH_SCENE_DATA_GLSL
#define VKMECH_SCENE_DATA_GLSL

#ifndef KERNEL_GPU
#extension GL_EXT_samplerless_texture_functions : require
#endif
#include "features.glsl"

layout(std140, set = 0, binding = BINDING_PARAMS) uniform ParamsBlock { GpuParams params; };
// The scene arrays hold RGBA32 uint texels, one per vec4 of the host structs
// (shared/types.h). The CPU kernel reads them as uniform texel buffers: a
// texel fetch loads a whole vec4 per invocation, where on lavapipe a
// storage-buffer load at a divergent address loops over the invocations. The
// GPU kernel (KERNEL_GPU) reads the same words as storage buffers of uvec4,
// plain global loads on a GPU (host GpuScene, docs/gpu.md).
#ifdef KERNEL_GPU
layout(std430, set = 0, binding = BINDING_VERTICES) readonly buffer VertexBuf { uvec4 vertex_buf[]; };        // GpuVertex: 2
layout(std430, set = 0, binding = BINDING_TRIANGLES) readonly buffer TriangleBuf { uvec4 triangle_buf[]; };   // 1
layout(std430, set = 0, binding = BINDING_MATERIALS) readonly buffer MaterialBuf { uvec4 material_buf[]; };   // GpuMaterial: MATERIAL_WORDS
layout(std430, set = 0, binding = BINDING_LIGHT_TRIS) readonly buffer LightTriBuf { uvec4 light_tri_buf[]; }; // GpuLightTriangle: 2
layout(std430, set = 0, binding = BINDING_EMITTERS) readonly buffer EmitterBuf { uvec4 emitter_buf[]; };      // GpuEmitter: 2
layout(std430, set = 0, binding = BINDING_TEXELS) readonly buffer TexelBuf { uvec4 texel_buf[]; };            // linear RGB
layout(std430, set = 0, binding = BINDING_TEXTURES) readonly buffer TextureBuf { uvec4 texture_buf[]; };      // TEX_WORDS each
layout(std430, set = 0, binding = BINDING_ENVIRONMENT) readonly buffer EnvBuf { uvec4 env_buf[]; };            // GpuEnvironment, GpuDirectional
#define SCENE_FETCH(b, i) b[i]
#define SCENE_FETCH_F(b, i) uintBitsToFloat(b[i])
#else
layout(set = 0, binding = BINDING_VERTICES) uniform utextureBuffer vertex_buf;      // GpuVertex: 2 texels
layout(set = 0, binding = BINDING_TRIANGLES) uniform utextureBuffer triangle_buf;   // uvec4
layout(set = 0, binding = BINDING_MATERIALS) uniform utextureBuffer material_buf;   // GpuMaterial: MATERIAL_WORDS texels
layout(set = 0, binding = BINDING_LIGHT_TRIS) uniform utextureBuffer light_tri_buf; // GpuLightTriangle: 2 texels
layout(set = 0, binding = BINDING_EMITTERS) uniform utextureBuffer emitter_buf;     // GpuEmitter: 2 texels
layout(set = 0, binding = BINDING_TEXELS) uniform utextureBuffer texel_buf;         // vec4 (linear RGB)
layout(set = 0, binding = BINDING_TEXTURES) uniform utextureBuffer texture_buf;     // uvec4, TEX_WORDS per texture
layout(set = 0, binding = BINDING_ENVIRONMENT) uniform utextureBuffer env_buf;      // GpuEnvironment, GpuDirectional
vec4 fetch_vec4(utextureBuffer b, uint i) { return uintBitsToFloat(texelFetch(b, int(i))); }
#define SCENE_FETCH(b, i) texelFetch(b, int(i))
#define SCENE_FETCH_F(b, i) fetch_vec4(b, i)
#endif
// SCENE_FETCH(b, i), SCENE_FETCH_F(b, i): word i of scene array b, as uvec4 and as vec4.

vec3 vertex_position(uint i) { return SCENE_FETCH_F(vertex_buf, 2u * i).xyz; }
vec3 vertex_normal(uint i) { return SCENE_FETCH_F(vertex_buf, 2u * i + 1u).xyz; }
vec2 vertex_uv(uint i) { return vec2(SCENE_FETCH_F(vertex_buf, 2u * i).w, SCENE_FETCH_F(vertex_buf, 2u * i + 1u).w); }
uvec4 triangle_at(uint i) { return SCENE_FETCH(triangle_buf, i); }
// Fetches only what the material's BSDF reads (the fields left out read 0; principled's
// parameter textures, word 10, only in textured scenes):
// a diffuse material reads its header and reflectance, two texels of eleven
// (three in textured scenes, which read the frame textures' word too);
// `k` only conductors and plastics read, the last three only principled and
// rough plastic (its tables), so scenes without those families (the feature
// constants) never fetch them. A texel fetch is a function call per SIMD
// vector on lavapipe, skipped when no invocation of the vector needs it.
GpuMaterial material_at(uint i) {
    uint b = MATERIAL_WORDS * i;
    const vec4 zero = vec4(0.0);
    GpuMaterial m = GpuMaterial(SCENE_FETCH(material_buf, b), SCENE_FETCH_F(material_buf, b + 1u), zero, zero, zero, zero, zero,
                                zero, zero, uvec4(0u), uvec4(0u));
    if (FEATURE_TEXTURES) m.frame_tex = SCENE_FETCH(material_buf, b + 9u);
    if (m.header.x != MAT_DIFFUSE) {
        m.specular_reflectance = SCENE_FETCH_F(material_buf, b + 2u);
        m.specular_transmittance = SCENE_FETCH_F(material_buf, b + 3u);
        m.eta = SCENE_FETCH_F(material_buf, b + 4u);
        if (FEATURE_CONDUCTOR || FEATURE_PLASTIC) m.k = SCENE_FETCH_F(material_buf, b + 5u);
        if (FEATURE_PRINCIPLED || (FEATURE_PLASTIC && FEATURE_ROUGH)) {
            m.model0 = SCENE_FETCH_F(material_buf, b + 6u);
            m.model1 = SCENE_FETCH_F(material_buf, b + 7u);
            m.model2 = SCENE_FETCH_F(material_buf, b + 8u);
        }
        if (FEATURE_PRINCIPLED && FEATURE_TEXTURES && m.header.x == MAT_PRINCIPLED)
            m.param_tex = SCENE_FETCH(material_buf, b + 10u);
    }
    return m;
}
GpuLightTriangle light_tri_at(uint i) {
    return GpuLightTriangle(SCENE_FETCH(light_tri_buf, 2u * i), SCENE_FETCH_F(light_tri_buf, 2u * i + 1u));
}
float light_tri_cdf(uint i) { return SCENE_FETCH_F(light_tri_buf, 2u * i + 1u).x; }
GpuEmitter emitter_at(uint i) { return GpuEmitter(SCENE_FETCH_F(emitter_buf, 2u * i), SCENE_FETCH(emitter_buf, 2u * i + 1u)); }
vec3 emitter_radiance(uint i) { return SCENE_FETCH_F(emitter_buf, 2u * i).rgb; }

vec3 texel_at(uvec4 info, float x, float y) {
    float w = float(info.y);
    float h = float(info.z);
    uint xi = uint(clamp(mod(x, w), 0.0, w - 1.0));
    uint yi = uint(clamp(mod(y, h), 0.0, h - 1.0));
    return SCENE_FETCH_F(texel_buf, info.x + yi * info.y + xi).rgb;
}

// Mitsuba's bitmap (bilinear or nearest, repeat wrap) and checkerboard
// textures after their to_uv transform; uv (0, 0) is the top-left corner of
// an image (host/scene convention).
vec3 texture_lookup(uint tex, vec2 uv_in) {
    uvec4 info = SCENE_FETCH(texture_buf, TEX_WORDS * tex);
    uvec4 r0 = SCENE_FETCH(texture_buf, TEX_WORDS * tex + 1u);
    uvec4 r1 = SCENE_FETCH(texture_buf, TEX_WORDS * tex + 2u);
    vec2 uv = vec2(dot(uintBitsToFloat(r0.xyz), vec3(uv_in, 1.0)), dot(uintBitsToFloat(r1.xyz), vec3(uv_in, 1.0)));
    uint kind = info.w & 0xFFu;
    if (kind == TEX_CHECKERBOARD) {
        // Mitsuba 3: colour 0 where exactly one of frac(u), frac(v) exceeds 1/2.
        vec2 f = uv - floor(uv);
        bool mu = f.x > 0.5;
        bool mv = f.y > 0.5;
        return SCENE_FETCH_F(texel_buf, info.x + (mu != mv ? 0u : 1u)).rgb;
    }
    vec2 p = uv * vec2(float(info.y), float(info.z));
    if ((info.w & TEX_NEAREST_BIT) != 0u) return texel_at(info, floor(p.x), floor(p.y));
    p -= 0.5;
    vec2 f = floor(p);
    vec2 t = p - f;
    vec3 c00 = texel_at(info, f.x, f.y);
    vec3 c10 = texel_at(info, f.x + 1.0, f.y);
    vec3 c01 = texel_at(info, f.x, f.y + 1.0);
    vec3 c11 = texel_at(info, f.x + 1.0, f.y + 1.0);
    return mix(mix(c00, c10, t.x), mix(c01, c11, t.x), t.y);
}

// The uv gradient of a texture's luminance at uv_in (Mitsuba 3's eval_1_grad): the bilinear
// interpolant's derivatives in texel units times the resolution, taken back through the to_uv
// transform (its transpose); zero for nearest lookups and checkerboards, which are piecewise
// constant.
vec2 texture_luminance_gradient(uint tex, vec2 uv_in) {
    uvec4 info = SCENE_FETCH(texture_buf, TEX_WORDS * tex);
    if ((info.w & 0xFFu) == TEX_CHECKERBOARD || (info.w & TEX_NEAREST_BIT) != 0u) return vec2(0.0);
    vec3 a = uintBitsToFloat(SCENE_FETCH(texture_buf, TEX_WORDS * tex + 1u).xyz);
    vec3 b = uintBitsToFloat(SCENE_FETCH(texture_buf, TEX_WORDS * tex + 2u).xyz);
    vec2 uv = vec2(dot(a, vec3(uv_in, 1.0)), dot(b, vec3(uv_in, 1.0)));
    vec2 size = vec2(float(info.y), float(info.z));
    vec2 p = uv * size - 0.5;
    vec2 f = floor(p);
    vec2 t = p - f;
    vec3 w = vec3(LUM_R, LUM_G, LUM_B);
    float c00 = dot(texel_at(info, f.x, f.y), w);
    float c10 = dot(texel_at(info, f.x + 1.0, f.y), w);
    float c01 = dot(texel_at(info, f.x, f.y + 1.0), w);
    float c11 = dot(texel_at(info, f.x + 1.0, f.y + 1.0), w);
    vec2 g = vec2(mix(c10 - c00, c11 - c01, t.y), mix(c01 - c00, c11 - c10, t.x)) * size;  // d/d(to_uv's u, v)
    return vec2(a.x * g.x + b.x * g.y, a.y * g.x + b.y * g.y);
}

// Emitters at infinity (shaders/environment.glsl, shared/types.h GpuEnvironment).
#define ENV_TEXEL(i) SCENE_FETCH_F(texel_buf, i)
#include "environment.glsl"
GpuEnvironment environment_at() {
    return GpuEnvironment(SCENE_FETCH_F(env_buf, 0u), SCENE_FETCH_F(env_buf, 1u), SCENE_FETCH_F(env_buf, 2u),
                          SCENE_FETCH_F(env_buf, 3u), SCENE_FETCH(env_buf, 4u));
}
GpuDirectional directional_at(uint i) {
    return GpuDirectional(SCENE_FETCH_F(env_buf, ENV_WORDS + 2u * i), SCENE_FETCH_F(env_buf, ENV_WORDS + 2u * i + 1u));
}

// The emission texture's slot of material i (texture + 1, 0: none; shared/types.h).
uint emission_slot(uint i) {
    return (SCENE_FETCH(material_buf, MATERIAL_WORDS * i).y >> MAT_EMISSION_TEX_SHIFT) & MAT_EMISSION_TEX_MASK;
}
// What an emitter's radiance is multiplied by at uv on a mesh of material i:
// its emission texture there, 1 without one (and in scenes without textures).
vec3 emission_scale(uint i, vec2 uv) {
    if (!FEATURE_TEXTURES) return vec3(1.0);
    uint slot = emission_slot(i);
    return slot != 0u ? texture_lookup(slot - 1u, uv) : vec3(1.0);
}

// The largest |coordinate| of three points: the magnitude that bounds the
// rounding error of a point interpolated between them (ray offsets below).
float max_abs3(vec3 a, vec3 b, vec3 c) {
    vec3 m = max(abs(a), max(abs(b), abs(c)));
    return max(m.x, max(m.y, m.z));
}

// The unit normal of the triangle with edges e1, e2 at any scene scale: the
// edges are first scaled by a power of two (exact) so that neither the cross
// product nor its squared length overflows (coordinates ~1e12) or underflows
// (~1e-12). Zero for a degenerate triangle, never NaN.
vec3 triangle_normal(vec3 e1, vec3 e2) {
    float m = max(max_abs3(e1, e2, vec3(0.0)), 1e-38);
    int ex;
    frexp(m, ex);
    vec3 c = cross(ldexp(e1, ivec3(-ex)), ldexp(e2, ivec3(-ex)));
    return dot(c, c) > 0.0 ? normalize(c) : vec3(0.0);
}

struct SurfaceHit {
    vec3 p;        // world position
    float scale;   // max |coordinate| of the hit triangle's vertices (ray offsets)
    vec3 ng;       // geometric normal (winding order)
    vec3 ns;       // shading normal, same hemisphere as ng
    vec2 uv;
    vec3 dpdu;     // textured scenes: dp/du of the triangle (zero where its uvs are degenerate)
    vec3 dpdv;     // textured scenes: dp/dv likewise
    uint material;
    uint emitter;  // emitter index + 1, 0 when not emissive
};

// The vertices' second texels (normal, v) are fetched only where they are
// read: at a triangle with normals, or for the uv of a textured scene.
SurfaceHit surface_hit(uint prim, vec2 bary) {
    uvec4 tri = triangle_at(prim);
    bool flat_tri = (tri.w & TRI_FLAT_BIT) != 0u;
    vec4 pa = SCENE_FETCH_F(vertex_buf, 2u * tri.x);
    vec4 pb = SCENE_FETCH_F(vertex_buf, 2u * tri.y);
    vec4 pc = SCENE_FETCH_F(vertex_buf, 2u * tri.z);
    vec4 na = vec4(0.0), nb = vec4(0.0), nc = vec4(0.0);
    if (!flat_tri || FEATURE_TEXTURES) {
        na = SCENE_FETCH_F(vertex_buf, 2u * tri.x + 1u);
        nb = SCENE_FETCH_F(vertex_buf, 2u * tri.y + 1u);
        nc = SCENE_FETCH_F(vertex_buf, 2u * tri.z + 1u);
    }
    float w0 = 1.0 - bary.x - bary.y;
    SurfaceHit s;
    s.p = w0 * pa.xyz + bary.x * pb.xyz + bary.y * pc.xyz;
    s.scale = max_abs3(pa.xyz, pb.xyz, pc.xyz);
    s.ng = triangle_normal(pb.xyz - pa.xyz, pc.xyz - pa.xyz);
    if (flat_tri) {
        s.ns = s.ng;
    } else {
        vec3 n = w0 * na.xyz + bary.x * nb.xyz + bary.y * nc.xyz;
        float len = length(n);
        s.ns = len > 0.0 ? n / len : s.ng;
        if (dot(s.ns, s.ng) < 0.0) s.ng = -s.ng;  // winding disagrees with the authored normals
    }
    s.uv = w0 * vec2(pa.w, na.w) + bary.x * vec2(pb.w, nb.w) + bary.y * vec2(pc.w, nc.w);
    s.dpdu = vec3(0.0);
    s.dpdv = vec3(0.0);
    if (FEATURE_TEXTURES) {
        // dp/du, dp/dv from the edges and their uv differences (a normal map's tangent, a bump
        // map's surface derivatives).
        vec2 d1 = vec2(pb.w - pa.w, nb.w - na.w);
        vec2 d2 = vec2(pc.w - pa.w, nc.w - na.w);
        float det = d1.x * d2.y - d1.y * d2.x;
        if (det != 0.0) {
            s.dpdu = ((pb.xyz - pa.xyz) * d2.y - (pc.xyz - pa.xyz) * d1.y) / det;
            s.dpdv = ((pc.xyz - pa.xyz) * d1.x - (pb.xyz - pa.xyz) * d2.x) / det;
        }
        if (FEATURE_TANGENTS && (tri.w & TRI_TANGENT_BIT) != 0u) {
            // The file's tangents (glTF's TANGENT), interpolated, give the normal map its frame
            // instead: dp/du along the tangent t, dp/dv against the bitangent w (ns x t) (glTF's v
            // runs down the image), whose sign normal_mapped's uv_handed test reads back.
            uint o = params.tangent_word_offset;
            vec4 t = w0 * SCENE_FETCH_F(vertex_buf, tri.x + o) + bary.x * SCENE_FETCH_F(vertex_buf, tri.y + o) +
                     bary.y * SCENE_FETCH_F(vertex_buf, tri.z + o);
            s.dpdu = t.xyz;
            s.dpdv = cross(s.ns, t.xyz) * (t.w < 0.0 ? 1.0 : -1.0);
        }
    }
    s.material = tri.w & TRI_MATERIAL_MASK;
    s.emitter = (tri.w >> TRI_EMITTER_SHIFT) & TRI_EMITTER_MASK;
    return s;
}

// Scale-aware self-intersection avoidance (docs/reliability.md, "Numerics"): the rounding error of
// a hit point interpolated from its triangle, and of the intersection test
// that must not find that triangle again from the new origin, is a few ulps
// of the triangle's largest coordinate (pbrt-v4's error bounds, Wächter &
// Binder's "A Fast and Robust Method for Avoiding Self-Intersection", Ray
// Tracing Gems ch. 6), so p moves along n by RAY_OFFSET_ULPS of that
// magnitude, with no absolute epsilon: a scene scaled by 1e-6 or 1e12
// renders the same image. `scale` is SurfaceHit.scale (LightSample.scale);
// n points to the side the new ray leaves from.
const float RAY_OFFSET_ULPS = 64.0;
vec3 offset_ray_origin(vec3 p, vec3 n, float scale) {
    float m = max(scale, max(abs(p.x), max(abs(p.y), abs(p.z))));
    return p + n * (RAY_OFFSET_ULPS * 1.1920929e-7 * m);
}

// The farthest t a ray is traced to: beyond any scene whose squared
// distances are representable (coordinates below ~1e19).
const float RAY_TMAX = 3.0e38;

float luminance(vec3 c) { return dot(c, vec3(LUM_R, LUM_G, LUM_B)); }

// Power-proportional light selection (host/engine/render/gpu_scene.cpp builds the cdf).
uint select_light_triangle(float u) {
    uint lo = 0u;
    uint hi = params.light_triangle_count - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        if (light_tri_cdf(mid) < u) lo = mid + 1u; else hi = mid;
    }
    return lo;
}

struct LightSample {
    vec3 p;
    vec3 n;         // emitting side
    vec3 radiance;
    float pdf_area; // selection * uniform area
    float scale;    // max |coordinate| of the light triangle (ray offsets)
};

// A point on light-table entry li (an emissive triangle, not an emitter at
// infinity), with u.y, u.z.
LightSample sample_light_triangle(uint li, vec3 u) {
    GpuLightTriangle lt = light_tri_at(li);
    uint prim = lt.info.x;
    uvec4 tri = triangle_at(prim);
    vec3 a = vertex_position(tri.x);
    vec3 b = vertex_position(tri.y);
    vec3 c = vertex_position(tri.z);
    float su = sqrt(u.y);
    float b0 = 1.0 - su;
    float b1 = u.z * su;
    LightSample s;
    s.p = b0 * a + b1 * b + (1.0 - b0 - b1) * c;
    s.n = triangle_normal(b - a, c - a);
    if ((tri.w & TRI_FLAT_BIT) == 0u) {
        // The emitting side follows the authored normals where the mesh has
        // them, exactly as at an emitter hit (surface_hit): a third-party mesh
        // whose winding disagrees with its normals emits on the same side
        // whether the light is sampled or hit.
        vec3 n = b0 * vertex_normal(tri.x) + b1 * vertex_normal(tri.y) + (1.0 - b0 - b1) * vertex_normal(tri.z);
        if (dot(n, s.n) < 0.0) s.n = -s.n;
    }
    s.scale = max_abs3(a, b, c);
    s.radiance = emitter_radiance(lt.info.y);
    if (FEATURE_TEXTURES) {
        uint slot = emission_slot(tri.w & TRI_MATERIAL_MASK);
        if (slot != 0u) {
            vec2 uv = b0 * vertex_uv(tri.x) + b1 * vertex_uv(tri.y) + (1.0 - b0 - b1) * vertex_uv(tri.z);
            s.radiance *= texture_lookup(slot - 1u, uv);
        }
    }
    s.pdf_area = lt.cdf.z;
    return s;
}

// Whether light-table entry li is an emitter at infinity (shared/types.h LIGHT_INFINITE).
bool light_is_infinite(uint li) { return FEATURE_ENVIRONMENT && SCENE_FETCH(light_tri_buf, 2u * li).x == LIGHT_INFINITE; }

// A direction towards an emitter at infinity: `index` 0 the environment, 1 + i
// directional light i; `selection` its selection probability.
struct InfiniteSample {
    vec3 wi;        // world direction towards the emitter
    vec3 radiance;  // the environment's radiance, or the directional light's irradiance
    float pdf;      // selection x solid-angle density; a directional light: the selection alone
    bool delta;     // a directional light (no BSDF sample can reach it)
};
InfiniteSample sample_infinite(uint index, float selection, vec2 u) {
    InfiniteSample s;
    if (index == 0u) {
        GpuEnvironment e = environment_at();
        s.wi = env_sample(e, u);
        s.pdf = selection * env_pdf(e, s.wi);
        s.radiance = env_eval(e, s.wi);
        s.delta = false;
    } else {
        GpuDirectional l = directional_at(index - 1u);
        s.wi = -l.direction.xyz;
        s.pdf = selection;
        s.radiance = l.irradiance.rgb;
        s.delta = true;
    }
    return s;
}

#endif
