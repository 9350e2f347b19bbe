// Emitters at infinity (docs/descriptor.md §1): the environment (Mitsuba's
// `constant` and lat-long `envmap`) and directional lights, evaluated and
// importance-sampled. Shared GLSL / C++ ("One code, two compilers"): the
// includer defines ENV_TEXEL(i), texel i of the texel array as a vec4
// (shaders/scene_data.glsl on the GPU, the chi-square tests in C++).
//
// The map's frame is Mitsuba 3's: +y up; a local direction
// (sin t sin p, cos t, -sin t cos p) is texture coordinate (u, v) = (p / 2 pi,
// t / pi), u wrapping around, v = 0 the top row. The radiance is bilinear
// between texel centres (wrapping in u, clamped in v). Sampling is
// piecewise constant over the pixels: each pixel's weight is the largest
// luminance of its 3 x 3 neighbourhood (every bilinear value inside the pixel
// is a convex combination of those), times sin t at its centre, so the density
// is positive wherever the radiance is, and close to it in proportion.
#ifndef VKMECH_ENVIRONMENT_GLSL
#define VKMECH_ENVIRONMENT_GLSL

#include "glsl_cpp.h"
#include "sampling.glsl"
#include "shared/types.h"

#ifdef __cplusplus
namespace vkmech::shader {
using namespace vkmech::gpu;
#endif

SHARED_FN vec3 env_to_world(GpuEnvironment e, vec3 l) {
    return vec3(dot(vec3(e.to_world0), l), dot(vec3(e.to_world1), l), dot(vec3(e.to_world2), l));
}
// The rotation's transpose (its inverse).
SHARED_FN vec3 env_to_local(GpuEnvironment e, vec3 w) {
    return vec3(e.to_world0) * w.x + vec3(e.to_world1) * w.y + vec3(e.to_world2) * w.z;
}

// A unit local direction's texture coordinates, u in [0, 1), v in [0, 1].
SHARED_FN vec2 env_dir_to_uv(vec3 l) {
    float u = atan(l.x, -l.z) * VKM_INV_TWO_PI;
    if (u < 0.0) u += 1.0;
    if (u >= 1.0) u = 0.0;
    return vec2(u, acos(min(max(l.y, float(-1.0)), float(1.0))) * VKM_INV_PI);
}
SHARED_FN vec3 env_uv_to_dir(vec2 uv) {
    float theta = uv.y * VKM_PI;
    float phi = uv.x * VKM_TWO_PI;
    float st = sin(theta);
    return vec3(st * sin(phi), cos(theta), -st * cos(phi));
}

SHARED_FN vec3 env_texel_rgb(GpuEnvironment e, int x, int y) {
    int w = int(e.map.z);
    int h = int(e.map.w);
    if (x < 0) x += w;  // x is in [-1, w]: one wrap either way
    if (x >= w) x -= w;
    y = min(max(y, 0), h - 1);
    return vec3(ENV_TEXEL(e.map.y + uint(y) * e.map.z + uint(x)));
}

// The map's radiance (times its scale) towards local direction l.
SHARED_FN vec3 env_map_eval_local(GpuEnvironment e, vec3 l) {
    vec2 uv = env_dir_to_uv(l);
    float px = uv.x * float(e.map.z) - 0.5;
    float py = uv.y * float(e.map.w) - 0.5;
    float fx = floor(px);
    float fy = floor(py);
    float tx = px - fx;
    float ty = py - fy;
    int x = int(fx);
    int y = int(fy);
    vec3 c0 = mix(env_texel_rgb(e, x, y), env_texel_rgb(e, x + 1, y), tx);
    vec3 c1 = mix(env_texel_rgb(e, x, y + 1), env_texel_rgb(e, x + 1, y + 1), tx);
    return vec3(e.radiance) * mix(c0, c1, ty);
}

// Radiance arriving from world direction d (pointing away from the scene): 0 without an environment.
SHARED_FN vec3 env_eval(GpuEnvironment e, vec3 d) {
    if (e.map.x == ENV_CONSTANT) return vec3(e.radiance);
    if (e.map.x == ENV_MAP) return env_map_eval_local(e, env_to_local(e, d));
    return vec3(0.0);
}

// The probability of pixel (x, y) under the sampling distribution, from the
// cdfs' differences: exactly the chance that env_sample's uniform numbers land
// in it.
SHARED_FN float env_map_pixel_prob(GpuEnvironment e, uint x, uint y) {
    uint w = e.map.z;
    uint h = e.map.w;
    uint marginal = e.map.y + w * h;
    float row_hi = ENV_TEXEL(marginal + y).x;
    float row_lo = y > 0u ? ENV_TEXEL(marginal + y - 1u).x : 0.0;
    uint row = e.map.y + y * w;
    float col_hi = ENV_TEXEL(row + x).w;
    float col_lo = x > 0u ? ENV_TEXEL(row + x - 1u).w : 0.0;
    return (row_hi - row_lo) * (col_hi - col_lo);
}

// Solid-angle density of env_sample's directions at world direction d
// (without the environment's selection probability).
SHARED_FN float env_pdf(GpuEnvironment e, vec3 d) {
    if (e.map.x == ENV_CONSTANT) return square_to_uniform_sphere_pdf();
    if (e.map.x != ENV_MAP) return 0.0;
    vec3 l = env_to_local(e, d);
    float sin_t = safe_sqrt(1.0 - l.y * l.y);
    if (!(sin_t > 0.0)) return 0.0;
    vec2 uv = env_dir_to_uv(l);
    uint x = min(uint(uv.x * float(e.map.z)), e.map.z - 1u);
    uint y = min(uint(uv.y * float(e.map.w)), e.map.w - 1u);
    float p = env_map_pixel_prob(e, x, y);
    // Uniform in (u, v) inside the pixel: density p w h per unit uv, and
    // d(omega) = 2 pi^2 sin t du dv.
    return p * float(e.map.z) * float(e.map.w) / (2.0 * VKM_PI * VKM_PI * sin_t);
}

// The first index i in [first, first + n) with u < cdf(i) (component c of the
// texels there; the last cdf is 1 and u < 1, so one exists).
SHARED_FN uint env_search(uint first, uint n, uint c, float u) {
    uint lo = 0u;
    uint hi = n - 1u;
    while (lo < hi) {
        uint mid = (lo + hi) / 2u;
        vec4 t = ENV_TEXEL(first + mid);
        float v = c == 0u ? t.x : t.w;
        if (v <= u) lo = mid + 1u;
        else hi = mid;
    }
    return lo;
}

// Where u falls between cdf values lo and hi, in [0, 1).
SHARED_FN float env_remap(float u, float lo, float hi) {
    return min((u - lo) / (hi - lo), float(0.99999994));
}

// A world direction towards the environment, distributed as env_pdf.
SHARED_FN vec3 env_sample(GpuEnvironment e, vec2 u) {
    if (e.map.x != ENV_MAP) {
        vec3 s = square_to_uniform_sphere(u);
        return e.map.x == ENV_CONSTANT ? s : vec3(0.0, 0.0, 1.0);
    }
    uint w = e.map.z;
    uint h = e.map.w;
    uint marginal = e.map.y + w * h;
    uint y = env_search(marginal, h, 0u, u.y);
    float v = env_remap(u.y, y > 0u ? ENV_TEXEL(marginal + y - 1u).x : 0.0, ENV_TEXEL(marginal + y).x);
    uint row = e.map.y + y * w;
    uint x = env_search(row, w, 3u, u.x);
    float s = env_remap(u.x, x > 0u ? ENV_TEXEL(row + x - 1u).w : 0.0, ENV_TEXEL(row + x).w);
    vec2 uv = vec2((float(x) + s) / float(w), (float(y) + v) / float(h));
    return env_to_world(e, env_uv_to_dir(uv));
}

#ifdef __cplusplus
}  // namespace vkmech::shader
#endif

#endif
