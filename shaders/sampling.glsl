// Warps from the unit square to directions and points (docs/architecture.md, "One code, two
// compilers": GLSL include and, unchanged, C++ for the doctest chi-square
// tests). Each warp has its density beside it, in the measure named there.
// Conventions: local frame, z up; u in [0, 1)^2.
#ifndef VKMECH_SAMPLING_GLSL
#define VKMECH_SAMPLING_GLSL

#include "glsl_cpp.h"

#ifdef __cplusplus
namespace vkmech::shader {
#endif

const float VKM_PI = 3.14159265358979323846;
const float VKM_TWO_PI = 6.28318530717958647692;
const float VKM_INV_PI = 0.31830988618379067154;
const float VKM_INV_TWO_PI = 0.15915494309189533577;
const float VKM_INV_FOUR_PI = 0.07957747154594766788;
const float VKM_SQRT_PI = 1.77245385090551602730;
const float VKM_INV_SQRT_PI = 0.56418958354775628695;

SHARED_FN float saturate(float x) { return min(max(x, float(0.0)), float(1.0)); }
SHARED_FN float sqr(float x) { return x * x; }
// sqrt that treats a slightly negative argument (rounding) as 0.
SHARED_FN float safe_sqrt(float x) { return sqrt(max(x, float(0.0))); }
SHARED_FN float mean3(vec3 v) { return (v.x + v.y + v.z) * float(1.0 / 3.0); }
SHARED_FN float max3(vec3 v) { return max(v.x, max(v.y, v.z)); }

// Veach's power heuristic (beta = 2, one sample per strategy): the MIS weight
// of the strategy with density a against one with density b.
SHARED_FN float power_heuristic(float a, float b) {
    float a2 = a * a;
    float b2 = b * b;
    return a2 + b2 > 0.0 ? a2 / (a2 + b2) : 0.0;
}

// Shirley-Chiu concentric map to the unit disk; density 1/pi per unit area.
// Keeps strata compact, so cosine-weighted samples stay well distributed.
SHARED_FN vec2 square_to_uniform_disk_concentric(vec2 u) {
    float x = 2.0 * u.x - 1.0;
    float y = 2.0 * u.y - 1.0;
    if (x == 0.0 && y == 0.0) return vec2(0.0);
    float r;
    float phi;
    if (abs(x) > abs(y)) {
        r = x;
        phi = (0.25 * VKM_PI) * (y / x);
    } else {
        r = y;
        phi = 0.5 * VKM_PI - (0.25 * VKM_PI) * (x / y);
    }
    return vec2(r * cos(phi), r * sin(phi));
}

// Polar map to the unit disk; density 1/pi per unit area.
SHARED_FN vec2 square_to_uniform_disk(vec2 u) {
    float r = sqrt(u.x);
    float phi = VKM_TWO_PI * u.y;
    return vec2(r * cos(phi), r * sin(phi));
}
SHARED_FN float square_to_uniform_disk_pdf() { return VKM_INV_PI; }

// Uniform on the unit sphere; density 1/(4 pi) per steradian.
SHARED_FN vec3 square_to_uniform_sphere(vec2 u) {
    float z = 1.0 - 2.0 * u.x;
    float r = safe_sqrt(1.0 - z * z);
    float phi = VKM_TWO_PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}
SHARED_FN float square_to_uniform_sphere_pdf() { return VKM_INV_FOUR_PI; }

// Uniform on the upper hemisphere; density 1/(2 pi) per steradian.
SHARED_FN vec3 square_to_uniform_hemisphere(vec2 u) {
    float z = u.x;
    float r = safe_sqrt(1.0 - z * z);
    float phi = VKM_TWO_PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}
SHARED_FN float square_to_uniform_hemisphere_pdf(vec3 v) { return v.z >= 0.0 ? VKM_INV_TWO_PI : 0.0; }

// Cosine-weighted upper hemisphere (Malley: lift the concentric disk);
// density cos(theta)/pi per steradian, 0 below the horizon.
SHARED_FN vec3 square_to_cosine_hemisphere(vec2 u) {
    vec2 d = square_to_uniform_disk_concentric(u);
    float z = safe_sqrt(1.0 - d.x * d.x - d.y * d.y);
    return vec3(d.x, d.y, z);
}
SHARED_FN float square_to_cosine_hemisphere_pdf(vec3 v) { return v.z > 0.0 ? v.z * VKM_INV_PI : 0.0; }

// Uniform in the cone around +z with cos(theta) >= cos_max; density
// 1 / (2 pi (1 - cos_max)) per steradian inside the cone.
SHARED_FN vec3 square_to_uniform_cone(vec2 u, float cos_max) {
    float z = 1.0 - u.x * (1.0 - cos_max);
    float r = safe_sqrt(1.0 - z * z);
    float phi = VKM_TWO_PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}
SHARED_FN float square_to_uniform_cone_pdf(vec3 v, float cos_max) {
    return v.z >= cos_max ? VKM_INV_TWO_PI / (1.0 - cos_max) : 0.0;
}

// Uniform barycentrics on a triangle (area density 2 on the unit triangle).
SHARED_FN vec2 square_to_uniform_triangle(vec2 u) {
    float t = sqrt(1.0 - u.x);
    return vec2(1.0 - t, u.y * t);
}

#ifdef __cplusplus
}  // namespace vkmech::shader
#endif

#endif
