// Fresnel terms and the reflect / refract helpers that go with them, in the
// conventions of Mitsuba 3 (src/render/fresnel.h) so that results compare:
// directions point away from the surface, eta = interior IOR / exterior IOR,
// and a negative cos_theta_i means "arriving from the inside".
#ifndef VKMECH_FRESNEL_GLSL
#define VKMECH_FRESNEL_GLSL

#include "glsl_cpp.h"
#include "sampling.glsl"

#ifdef __cplusplus
namespace vkmech::shader {
#endif

// Unpolarized Fresnel reflectance of a dielectric interface.
// cos_theta_i: cosine between the incident direction and the normal (signed:
// < 0 means the direction lies inside). Outputs: cos_theta_t, the signed
// cosine of the transmitted direction (opposite sign to cos_theta_i, 0 under
// total internal reflection); eta_it, the relative IOR the transmitted ray
// crosses (eta when entering, 1/eta when leaving), and eta_ti = 1/eta_it, the
// factor refract_about() scales the tangential part with.
SHARED_FN float fresnel_dielectric(float cos_theta_i, float eta, OUT(float) cos_theta_t, OUT(float) eta_it,
                                   OUT(float) eta_ti) {
    bool outside = cos_theta_i >= 0.0;
    float rcp_eta = 1.0 / eta;
    eta_it = outside ? eta : rcp_eta;
    eta_ti = outside ? rcp_eta : eta;
    // Snell: sin^2(theta_t) = eta_ti^2 sin^2(theta_i).
    float sin_i_sqr = 1.0 - cos_theta_i * cos_theta_i;
    float cos_t_sqr = 1.0 - eta_ti * eta_ti * max(sin_i_sqr, float(0.0));
    float ci = abs(cos_theta_i);
    float ct = safe_sqrt(cos_t_sqr);
    cos_theta_t = cos_theta_i >= 0.0 ? -ct : ct;
    if (eta == 1.0) {
        cos_theta_t = -cos_theta_i;
        return 0.0;  // index-matched: no interface
    }
    if (ci == 0.0) return 1.0;  // grazing
    // Amplitude ratios of the s- and p-polarized reflected waves.
    float a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    float a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    return saturate(0.5 * (a_s * a_s + a_p * a_p));
}

// Reflectance only (when the transmitted direction is not needed).
SHARED_FN float fresnel_dielectric_r(float cos_theta_i, float eta) {
    float cos_t;
    float eta_it;
    float eta_ti;
    return fresnel_dielectric(cos_theta_i, eta, cos_t, eta_it, eta_ti);
}

// Unpolarized reflectance of a conductor with complex relative IOR eta + i k
// for one wavelength (one RGB channel); cos_theta_i >= 0 (its magnitude is
// used). eta = 0, k = 1 gives exactly 1 at every angle (Mitsuba's "none").
SHARED_FN float fresnel_conductor1(float cos_theta_i, float eta, float k) {
    float c = min(abs(cos_theta_i), float(1.0));
    float c2 = c * c;
    float s2 = 1.0 - c2;
    float s4 = s2 * s2;
    // a^2 + b^2 = |eta^2 - sin^2|, with eta complex; a = Re sqrt(eta^2 - sin^2).
    float t1 = eta * eta - k * k - s2;
    float a2pb2 = safe_sqrt(t1 * t1 + 4.0 * k * k * eta * eta);
    float a = safe_sqrt(0.5 * (a2pb2 + t1));
    float term1 = a2pb2 + c2;
    float term2 = 2.0 * c * a;
    float denom_s = term1 + term2;
    float r_s = denom_s > 0.0 ? (term1 - term2) / denom_s : 1.0;
    float term3 = a2pb2 * c2 + s4;
    float term4 = term2 * s2;
    float denom_p = term3 + term4;
    float r_p = denom_p > 0.0 ? r_s * (term3 - term4) / denom_p : r_s;
    return saturate(0.5 * (r_s + r_p));
}

SHARED_FN vec3 fresnel_conductor(float cos_theta_i, vec3 eta, vec3 k) {
    return vec3(fresnel_conductor1(cos_theta_i, eta.x, k.x), fresnel_conductor1(cos_theta_i, eta.y, k.y),
                fresnel_conductor1(cos_theta_i, eta.z, k.z));
}

// Hemispherical average of the dielectric Fresnel reflectance, 2 int F mu dmu,
// for light arriving from the side with relative IOR eta: the two published
// fits Mitsuba uses (Egan & Hilgeman 1973 for eta < 1, d'Eon & Irving 2011
// otherwise).
SHARED_FN float fresnel_diffuse_reflectance(float eta) {
    if (eta < 1.0) {
        return -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta;
    }
    float x = 1.0 / eta;
    return 0.919317 + x * (-3.4793 + x * (6.75335 + x * (-7.80989 + x * (4.98554 + x * -1.36881))));
}

// Schlick's weight (1 - cos)^5, cos clamped to [0, 1].
SHARED_FN float schlick_weight(float cos_theta) {
    float m = saturate(1.0 - cos_theta);
    float m2 = m * m;
    return m2 * m2 * m;
}

// Normal-incidence reflectance of a dielectric with relative IOR eta.
SHARED_FN float schlick_r0_eta(float eta) { return sqr((eta - 1.0) / (eta + 1.0)); }

// Schlick's approximation as Mitsuba's principled BSDF uses it: with the
// incident cosine when light goes into the denser medium, with the
// transmitted cosine otherwise (1 under total internal reflection).
SHARED_FN float schlick_fresnel_angle_weight(float cos_theta_i, float eta) {
    bool outside = cos_theta_i >= 0.0;
    float eta_it = outside ? eta : 1.0 / eta;
    float eta_ti = outside ? 1.0 / eta : eta;
    if (eta_it > 1.0) return schlick_weight(abs(cos_theta_i));
    float sin_i_sqr = 1.0 - cos_theta_i * cos_theta_i;
    float cos_t_sqr = 1.0 - eta_ti * eta_ti * max(sin_i_sqr, float(0.0));
    return schlick_weight(safe_sqrt(cos_t_sqr));
}
SHARED_FN float schlick_fresnel(float r0, float cos_theta_i, float eta) {
    return r0 + (1.0 - r0) * schlick_fresnel_angle_weight(cos_theta_i, eta);
}
SHARED_FN vec3 schlick_fresnel3(vec3 r0, float cos_theta_i, float eta) {
    float w = schlick_fresnel_angle_weight(cos_theta_i, eta);
    return r0 + (vec3(1.0) - r0) * w;
}

// Mirror v about the normal +z.
SHARED_FN vec3 reflect_z(vec3 v) { return vec3(-v.x, -v.y, v.z); }
// Mirror v about the unit vector m (v and the result point away from the surface).
SHARED_FN vec3 reflect_about(vec3 v, vec3 m) {
    float d = 2.0 * dot(v, m);
    return d * m - v;
}
// Refract v through the interface with normal m; cos_theta_t and eta_ti are
// the outputs of fresnel_dielectric(dot(v, m), eta). The result points away
// from the surface on the other side.
SHARED_FN vec3 refract_about(vec3 v, vec3 m, float cos_theta_t, float eta_ti) {
    float a = dot(v, m) * eta_ti + cos_theta_t;
    return a * m - eta_ti * v;
}
// Refract through the macro-surface (m = +z).
SHARED_FN vec3 refract_z(vec3 v, float cos_theta_t, float eta_ti) {
    return vec3(-eta_ti * v.x, -eta_ti * v.y, cos_theta_t);
}

#ifdef __cplusplus
}  // namespace vkmech::shader
#endif

#endif
