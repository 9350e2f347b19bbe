// Microfacet distributions (Beckmann and GGX, anisotropic), Smith masking,
// and visible-normal (VNDF) sampling: GGX by Heitz 2018 ("Sampling the GGX
// distribution of visible normals"), Beckmann by the slope-space method of
// Heitz & d'Eon 2014 with a bracketed Newton inversion of the visible-slope
// CDF (after Jakob's formulation). The sampled density of m is
//   D_wi(m) = G1(wi, m) max(0, wi.m) D(m) / wi.z       (mf_pdf_visible)
// which needs the exact Smith G1: Beckmann's is evaluated with erfc, not with
// the rational fit Mitsuba uses, so sampling and pdf agree to float precision.
// Also the GTR1 distribution of the principled clearcoat.
#ifndef VKMECH_MICROFACET_GLSL
#define VKMECH_MICROFACET_GLSL

#include "glsl_cpp.h"
#include "sampling.glsl"

#ifdef __cplusplus
namespace vkmech::shader {
#endif

// ---- special functions (no GLSL built-ins for these) ----

// erfc with relative error < 1.2e-7 everywhere (the Chebyshev fit of
// Numerical Recipes' erfcc); relative accuracy in the tail is what the
// Beckmann Smith term needs.
SHARED_FN float vkm_erfc(float x) {
    float z = abs(x);
    float t = 1.0 / (1.0 + 0.5 * z);
    float p = -0.82215223 + t * 0.17087277;
    p = 1.48851587 + t * p;
    p = -1.13520398 + t * p;
    p = 0.27886807 + t * p;
    p = -0.18628806 + t * p;
    p = 0.09678418 + t * p;
    p = 0.37409196 + t * p;
    p = 1.00002368 + t * p;
    p = -1.26551223 + t * p;
    float r = t * exp(-z * z + p);
    return x >= 0.0 ? r : 2.0 - r;
}

// erf: Maclaurin series near 0 (keeps relative accuracy there), 1 - erfc beyond.
SHARED_FN float vkm_erf(float x) {
    float z = abs(x);
    if (z < 0.5) {
        float x2 = x * x;
        float s = -1.0 / 1320.0;
        s = 1.0 / 216.0 + x2 * s;
        s = -1.0 / 42.0 + x2 * s;
        s = 0.1 + x2 * s;
        s = -1.0 / 3.0 + x2 * s;
        s = 1.0 + x2 * s;
        return (2.0 * VKM_INV_SQRT_PI) * x * s;
    }
    float r = 1.0 - vkm_erfc(z);
    return x >= 0.0 ? r : -r;
}

// Inverse error function on (-1, 1): M. Giles' single-precision
// approximation ("Approximating the erfinv function", GPU Gems 4 draft, 2010).
SHARED_FN float vkm_erfinv(float x) {
    float q = (1.0 - x) * (1.0 + x);
    float w = -log(max(q, float(1e-30)));
    float p;
    if (w < 5.0) {
        w = w - 2.5;
        p = 2.81022636e-08;
        p = 3.43273939e-07 + p * w;
        p = -3.5233877e-06 + p * w;
        p = -4.39150654e-06 + p * w;
        p = 0.00021858087 + p * w;
        p = -0.00125372503 + p * w;
        p = -0.00417768164 + p * w;
        p = 0.246640727 + p * w;
        p = 1.50140941 + p * w;
    } else {
        w = sqrt(w) - 3.0;
        p = -0.000200214257;
        p = 0.000100950558 + p * w;
        p = 0.00134934322 + p * w;
        p = -0.00367342844 + p * w;
        p = 0.00573950773 + p * w;
        p = -0.0076224613 + p * w;
        p = 0.00943887047 + p * w;
        p = 1.00167406 + p * w;
        p = 2.83297682 + p * w;
    }
    return p * x;
}

// ---- the distribution ----

const uint MF_BECKMANN = 0u;  // GpuMaterial.header.w, host MicrofacetDistribution
const uint MF_GGX = 1u;
const float MF_MIN_ALPHA = 1e-4;    // below this a lobe is a delta in disguise
const float MF_MIN_COS = 1e-7;      // |cos| below this counts as exactly grazing

struct Microfacet {
    uint type;
    float alpha_u;
    float alpha_v;
};

SHARED_FN Microfacet microfacet_make(uint type, float alpha_u, float alpha_v) {
    Microfacet d;
    d.type = type;
    d.alpha_u = max(alpha_u, MF_MIN_ALPHA);
    d.alpha_v = max(alpha_v, MF_MIN_ALPHA);
    return d;
}

// Normal distribution D(m), per steradian of m; 0 below the horizon.
SHARED_FN float mf_D(Microfacet d, vec3 m) {
    if (m.z <= 0.0) return 0.0;
    float z2 = m.z * m.z;
    float xu = m.x / d.alpha_u;
    float yv = m.y / d.alpha_v;
    float result;
    if (d.type == MF_BECKMANN) {
        if (z2 < 1e-12) return 0.0;  // exp(-tan^2/alpha^2) has long underflowed
        float e = (xu * xu + yv * yv) / z2;
        result = exp(-e) / (VKM_PI * d.alpha_u * d.alpha_v * z2 * z2);
    } else {
        float q = xu * xu + yv * yv + z2;
        result = 1.0 / (VKM_PI * d.alpha_u * d.alpha_v * q * q);
    }
    // Drop values too small to matter (keeps denormals out of products).
    return result * m.z > 1e-20 ? result : 0.0;
}

// Smith's monodirectional masking G1(v, m), exact for both distributions; 0
// when v sees the back of the facet or lies on the horizon.
SHARED_FN float mf_G1(Microfacet d, vec3 v, vec3 m) {
    if (dot(v, m) * v.z <= 0.0) return 0.0;
    float xy2 = sqr(d.alpha_u * v.x) + sqr(d.alpha_v * v.y);
    if (xy2 <= 0.0) return 1.0;  // normal incidence
    // a = cot(theta_v) / alpha(phi_v): large means little masking.
    float a = abs(v.z) / sqrt(xy2);
    if (d.type == MF_BECKMANN) {
        if (a > 8.0) return 1.0;  // Lambda < 1e-29
        // 1 / (1 + Lambda), Lambda = (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2,
        // multiplied through by 2 a sqrt(pi) so a -> 0 stays finite.
        float two_a_sqrt_pi = 2.0 * VKM_SQRT_PI * a;
        float num = exp(-a * a) - 0.5 * two_a_sqrt_pi * vkm_erfc(a);
        return two_a_sqrt_pi / (two_a_sqrt_pi + max(num, float(0.0)));
    }
    // GGX: 2 / (1 + sqrt(1 + 1/a^2)), rewritten to stay finite as a -> 0.
    return 2.0 * a / (a + sqrt(1.0 + a * a));
}

// Separable shadowing-masking G(wi, wo, m) = G1(wi, m) G1(wo, m).
SHARED_FN float mf_G(Microfacet d, vec3 wi, vec3 wo, vec3 m) { return mf_G1(d, wi, m) * mf_G1(d, wo, m); }

// Density of the visible normals seen from wi (wi.z > 0), per steradian of m.
SHARED_FN float mf_pdf_visible(Microfacet d, vec3 wi, vec3 m) {
    if (wi.z < MF_MIN_COS) return 0.0;
    float dm = mf_D(d, m);
    if (dm <= 0.0) return 0.0;
    return mf_G1(d, wi, m) * max(dot(wi, m), float(0.0)) * dm / wi.z;
}

// GGX visible normals (Heitz 2018): the hemisphere configuration, projected
// disk sampling in the stretched space, unstretch.
SHARED_FN vec3 mf_sample_visible_ggx(Microfacet d, vec3 wi, vec2 u) {
    vec3 vh = normalize(vec3(d.alpha_u * wi.x, d.alpha_v * wi.y, wi.z));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = lensq > 0.0 ? vec3(-vh.y, vh.x, 0.0) * inversesqrt(lensq) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    float r = sqrt(u.x);
    float phi = VKM_TWO_PI * u.y;
    float p1 = r * cos(phi);
    float p2 = r * sin(phi);
    float s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * safe_sqrt(1.0 - p1 * p1) + s * p2;
    float p3 = safe_sqrt(1.0 - p1 * p1 - p2 * p2);
    vec3 nh = p1 * t1 + p2 * t2 + p3 * vh;
    return normalize(vec3(d.alpha_u * nh.x, d.alpha_v * nh.y, max(nh.z, float(0.0))));
}

// Visible slopes of the isotropic alpha = 1 Beckmann surface seen from
// (sin_t, 0, cos_t). The y slope is an independent Gaussian; the x slope has
// the CDF, in the variable b = erf(x),
//   C(b) = (1 + b + tan_t / sqrt(pi) exp(-erfinv(b)^2)) / C(erf(cot_t)),
// which is inverted by Newton steps kept inside a shrinking bracket. Its
// derivative in b is 1 - x tan_t >= 0 on the visible range x <= cot_t.
SHARED_FN vec2 mf_beckmann_visible_slopes11(float cos_t, float sin_t, vec2 u) {
    const float B_MAX = 0.99999988;  // keeps erfinv finite (slopes within ~3.8)
    float uy = 2.0 * u.y - 1.0;
    uy = min(max(uy, -B_MAX), B_MAX);
    float slope_y = vkm_erfinv(uy);
    if (sin_t < 1e-4 * cos_t) {
        // Normal incidence: visible slopes are the Beckmann slopes themselves.
        float q = 1.0 - u.x;
        float r = sqrt(-log(max(q, float(1e-12))));
        float phi = VKM_TWO_PI * u.y;
        return vec2(r * cos(phi), r * sin(phi));
    }
    float tan_t = sin_t / cos_t;
    float cot_t = cos_t / sin_t;
    float k = tan_t * VKM_INV_SQRT_PI;
    float c = vkm_erf(cot_t);
    float total = 1.0 + c + k * exp(-cot_t * cot_t);
    float target = min(max(u.x, float(1e-7)), float(B_MAX)) * total;
    float lo = -B_MAX;
    float hi = min(c, B_MAX);
    float b = lo + u.x * (hi - lo);
    float tol = 1e-6 * total;
    for (int it = 0; it < 40; ++it) {
        if (!(b >= lo && b <= hi)) b = 0.5 * (lo + hi);
        float x = vkm_erfinv(b);
        float value = 1.0 + b + k * exp(-x * x) - target;
        if (abs(value) < tol) break;
        if (value > 0.0) {
            hi = b;
        } else {
            lo = b;
        }
        float deriv = 1.0 - x * tan_t;
        if (deriv > 1e-6) {
            b -= value / deriv;
        } else {
            b = 0.5 * (lo + hi);
        }
    }
    return vec2(vkm_erfinv(b), slope_y);
}

// Beckmann visible normals (Heitz & d'Eon 2014): stretch, sample the alpha = 1
// visible slopes in the plane of incidence, rotate, unstretch.
SHARED_FN vec3 mf_sample_visible_beckmann(Microfacet d, vec3 wi, vec2 u) {
    vec3 ws = normalize(vec3(d.alpha_u * wi.x, d.alpha_v * wi.y, max(wi.z, MF_MIN_COS)));
    float sin_t = sqrt(ws.x * ws.x + ws.y * ws.y);
    float cos_t = max(ws.z, MF_MIN_COS);
    vec2 s11 = mf_beckmann_visible_slopes11(cos_t, sin_t, u);
    float cos_phi = 1.0;
    float sin_phi = 0.0;
    if (sin_t > 0.0) {
        cos_phi = ws.x / sin_t;
        sin_phi = ws.y / sin_t;
    }
    float sx = (cos_phi * s11.x - sin_phi * s11.y) * d.alpha_u;
    float sy = (sin_phi * s11.x + cos_phi * s11.y) * d.alpha_v;
    return normalize(vec3(-sx, -sy, 1.0));
}

// A microfacet normal with density mf_pdf_visible(d, wi, m); wi.z > 0.
SHARED_FN vec3 mf_sample_visible(Microfacet d, vec3 wi, vec2 u) {
    if (d.type == MF_BECKMANN) return mf_sample_visible_beckmann(d, wi, u);
    return mf_sample_visible_ggx(d, wi, u);
}

// ---- GTR1 (Burley's "generalized Trowbridge-Reitz", gamma = 1): the
// principled clearcoat's normal distribution, isotropic, alpha < 1 ----

SHARED_FN float gtr1_D(float alpha, vec3 m) {
    if (m.z <= 0.0) return 0.0;
    float a2 = alpha * alpha;
    float result = (a2 - 1.0) / (VKM_PI * log(a2) * (1.0 + (a2 - 1.0) * m.z * m.z));
    return result * m.z > 1e-20 ? result : 0.0;
}
// Samples m with density gtr1_D(alpha, m) m.z per steradian.
SHARED_FN vec3 gtr1_sample(float alpha, vec2 u) {
    float a2 = alpha * alpha;
    float cos2 = (1.0 - pow(a2, 1.0 - u.y)) / (1.0 - a2);
    float cos_t = safe_sqrt(cos2);
    float sin_t = safe_sqrt(1.0 - cos2);
    float phi = VKM_TWO_PI * u.x;
    return normalize(vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t));
}
SHARED_FN float gtr1_pdf(float alpha, vec3 m) { return gtr1_D(alpha, m) * max(m.z, float(0.0)); }

// Isotropic GGX Smith G1 with a fixed alpha (the clearcoat's masking), with
// the same orientation rule as mf_G1.
SHARED_FN float smith_ggx1(vec3 v, vec3 m, float alpha) {
    if (dot(v, m) * v.z <= 0.0) return 0.0;
    float s2 = v.x * v.x + v.y * v.y;
    if (s2 <= 0.0) return 1.0;
    float a = abs(v.z) / (alpha * sqrt(s2));
    return 2.0 * a / (a + sqrt(1.0 + a * a));
}

#ifdef __cplusplus
}  // namespace vkmech::shader
#endif

#endif
