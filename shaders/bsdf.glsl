// The materials of docs/descriptor.md §2, following Mitsuba 3's definitions (src/bsdfs/*.cpp)
// so that renders compare with Mitsuba, written once for GLSL and C++
// (docs/architecture.md, "One code, two compilers").
//
// Local shading frame, z = shading normal. wo points from the surface toward
// the previous path vertex, wi is the sampled / evaluated direction; both are
// unit vectors. Values are for radiance transport:
//   bsdf_eval   = f(wo, wi) |cos wi| of the non-delta components,
//   bsdf_pdf    = the solid-angle density with which bsdf_sample produces wi
//                 through its non-delta components (selection included),
//   bsdf_sample = one direction; weight = f |cos wi| / p including the lobe
//                 selection probability (for a non-delta sample exactly
//                 bsdf_eval / bsdf_pdf at (wo, wi)); lobe = the component
//                 actually sampled, by Mitsuba's flag cascade
//                 Delta (S) > Diffuse (D) > Glossy (G).
// `albedo` is the reflectance after the caller's texture lookup: diffuse
// reflectance, plastic diffuse_reflectance, principled base_color.
//
// One-sided materials return nothing for wo.z <= 0 (as Mitsuba); with
// `twosided` set, a non-transmissive material mirrors wo and wi to the front.
// Transmissive materials (the dielectric family, principled with
// spec_trans > 0) see both sides and ignore `twosided`.
#ifndef VKMECH_BSDF_GLSL
#define VKMECH_BSDF_GLSL

#include "glsl_cpp.h"
#include "features.glsl"
#include "shared/types.h"
#include "sampling.glsl"
#include "fresnel.glsl"
#include "microfacet.glsl"
#include "lobes.glsl"

#ifdef __cplusplus
// Every model has the signatures the material table's dispatch calls
// (shared/materials.h), so some leave a parameter unused.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"
namespace vkmech::shader {
using namespace vkmech::gpu;
#endif

struct BsdfSample {
    vec3 wi;
    vec3 weight;  // f |cos wi| / pdf, lobe selection included
    float pdf;    // solid-angle pdf (all non-delta components); 0 for a delta lobe
    uint lobe;    // LOBE_D, LOBE_G or LOBE_S; LOBE_NONE when !ok
    bool ok;
    float eta;    // relative IOR crossed (eta_it), 1 for reflection
};

SHARED_FN BsdfSample bsdf_sample_none() {
    BsdfSample s;
    s.wi = vec3(0.0, 0.0, 1.0);
    s.weight = vec3(0.0);
    s.pdf = 0.0;
    s.lobe = LOBE_NONE;
    s.ok = false;
    s.eta = 1.0;
    return s;
}

// A non-delta sample: weight = f / pdf (no sample where the pdf is 0).
SHARED_FN BsdfSample bsdf_make_sample(vec3 wi, vec3 f, float pdf, uint lobe, float eta) {
    BsdfSample s = bsdf_sample_none();
    if (!(pdf > 0.0)) return s;
    s.wi = wi;
    s.weight = f / pdf;
    s.pdf = pdf;
    s.lobe = lobe;
    s.ok = true;
    s.eta = eta;
    return s;
}

// A delta sample (pdf 0 by convention).
SHARED_FN BsdfSample bsdf_make_delta(vec3 wi, vec3 weight, float eta) {
    BsdfSample s = bsdf_sample_none();
    s.wi = wi;
    s.weight = weight;
    s.lobe = LOBE_S;
    s.ok = true;
    s.eta = eta;
    return s;
}

SHARED_FN float bsdf_luminance(vec3 c) { return LUM_R * c.x + LUM_G * c.y + LUM_B * c.z; }

// ---- material fields (see GpuMaterial in shared/types.h) ----

SHARED_FN vec3 mat_specular_reflectance(GpuMaterial m) { return vec3(m.specular_reflectance); }
SHARED_FN vec3 mat_specular_transmittance(GpuMaterial m) { return vec3(m.specular_transmittance); }
// Relative IOR int_ior / ext_ior of the dielectric and plastic families.
SHARED_FN float mat_eta(GpuMaterial m) {
    float int_ior = m.specular_transmittance.w;
    float ext_ior = m.eta.w;
    float e = ext_ior > 0.0 ? int_ior / ext_ior : int_ior;
    return e > 0.0 ? e : 1.0;
}
// Microfacet roughness of the rough families (alpha_u, alpha_v, distribution).
SHARED_FN Microfacet mat_microfacet(GpuMaterial m) {
    return microfacet_make(m.header.w, m.reflectance.w, m.specular_reflectance.w);
}
// Conductor complex IOR relative to the exterior (Mitsuba 0.6's extEta; 1 in Mitsuba 3).
SHARED_FN vec3 mat_conductor_fresnel(GpuMaterial m, float cos_theta_i) {
    float ext = m.eta.w > 0.0 ? m.eta.w : 1.0;
    return fresnel_conductor(cos_theta_i, vec3(m.eta) / ext, vec3(m.k) / ext);
}

// ---- diffuse (Mitsuba `diffuse`) ----

SHARED_FN vec3 diffuse_eval_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    pdf = 0.0;
    if (wo.z <= 0.0 || wi.z <= 0.0) return vec3(0.0);
    pdf = wi.z * VKM_INV_PI;
    return albedo * pdf;
}

// The direction diffuse and roughdiffuse sample: cosine-weighted (square_to_cosine_hemisphere,
// whose density wi.z / pi is both models' pdf). False, with wi = +z, where neither model has
// density: wo below the surface, or the warp landing on the horizon (the disk's rim).
SHARED_FN bool cosine_weighted_wi(vec3 wo, vec2 u, OUT(vec3) wi) {
    wi = vec3(0.0, 0.0, 1.0);
    if (wo.z <= 0.0) return false;
    vec3 w = square_to_cosine_hemisphere(u);
    if (!(w.z > 0.0)) return false;
    wi = w;
    return true;
}

SHARED_FN BsdfSample diffuse_sample(GpuMaterial m, vec3 albedo, vec3 wo, float u_lobe, vec2 u) {
    vec3 wi;
    if (!cosine_weighted_wi(wo, u, wi)) return bsdf_sample_none();
    float pdf;
    vec3 f = diffuse_eval_pdf(m, albedo, wo, wi, pdf);
    return bsdf_make_sample(wi, f, pdf, LOBE_D, 1.0);
}

// A delta-only model has no non-delta component to evaluate.
SHARED_FN vec3 delta_only_eval_pdf(OUT(float) pdf) {
    pdf = 0.0;
    return vec3(0.0);
}

// ---- conductor (smooth; delta) ----

SHARED_FN vec3 conductor_eval_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    return delta_only_eval_pdf(pdf);
}

SHARED_FN BsdfSample conductor_sample(GpuMaterial m, vec3 albedo, vec3 wo, float u_lobe, vec2 u) {
    if (wo.z <= 0.0) return bsdf_sample_none();
    vec3 weight = mat_specular_reflectance(m) * mat_conductor_fresnel(m, wo.z);
    return bsdf_make_delta(reflect_z(wo), weight, 1.0);
}

// ---- roughconductor (microfacet reflection, VNDF sampling) ----

SHARED_FN vec3 roughconductor_eval_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    pdf = 0.0;
    if (wo.z < MF_MIN_COS || wi.z <= 0.0) return vec3(0.0);
    vec3 h = wo + wi;
    float l2 = dot(h, h);
    if (!(l2 > 1e-30)) return vec3(0.0);
    h = h * inversesqrt(l2);
    Microfacet d = mat_microfacet(m);
    float dh = mf_D(d, h);
    if (dh <= 0.0) return vec3(0.0);
    // pdf = D_wo(h) / (4 wi.h) = G1(wo) D / (4 wo.z), since wo.h = wi.h.
    float p = mf_G1(d, wo, h) * dh / (4.0 * wo.z);
    if (!(p > 0.0)) return vec3(0.0);
    pdf = p;
    // f |cos wi| = F D G1(wo) G1(wi) / (4 wo.z) = F G1(wi) pdf.
    float scale = mf_G1(d, wi, h) * p;
    return mat_specular_reflectance(m) * mat_conductor_fresnel(m, dot(wo, h)) * scale;
}

SHARED_FN BsdfSample roughconductor_sample(GpuMaterial m, vec3 albedo, vec3 wo, float u_lobe, vec2 u) {
    if (wo.z < MF_MIN_COS) return bsdf_sample_none();
    vec3 h = mf_sample_visible(mat_microfacet(m), wo, u);
    vec3 wi = reflect_about(wo, h);
    if (wi.z <= 0.0) return bsdf_sample_none();
    float pdf;
    vec3 f = roughconductor_eval_pdf(m, albedo, wo, wi, pdf);
    return bsdf_make_sample(wi, f, pdf, LOBE_G, 1.0);
}

// ---- dielectric (smooth; delta; both sides) ----

SHARED_FN vec3 dielectric_eval_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    return delta_only_eval_pdf(pdf);
}

SHARED_FN BsdfSample dielectric_sample(GpuMaterial m, vec3 albedo, vec3 wo, float u_lobe, vec2 u) {
    float cos_t;
    float eta_it;
    float eta_ti;
    float r = fresnel_dielectric(wo.z, mat_eta(m), cos_t, eta_it, eta_ti);
    if (u_lobe < r) return bsdf_make_delta(reflect_z(wo), mat_specular_reflectance(m), 1.0);
    // Radiance is scaled by 1/eta_it^2 (solid-angle compression), as Mitsuba
    // does in radiance mode.
    vec3 weight = mat_specular_transmittance(m) * (eta_ti * eta_ti);
    return bsdf_make_delta(refract_z(wo, cos_t, eta_ti), weight, eta_it);
}

// ---- thindielectric (delta reflection or straight pass-through) ----

SHARED_FN vec3 thindielectric_eval_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    return delta_only_eval_pdf(pdf);
}

SHARED_FN BsdfSample thindielectric_sample(GpuMaterial m, vec3 albedo, vec3 wo, float u_lobe, vec2 u) {
    float f = fresnel_dielectric_r(abs(wo.z), mat_eta(m));
    // All the bounces inside the sheet: R = F + (1-F)^2 F / (1 - F^2) = 2F / (1+F).
    float r = 2.0 * f / (1.0 + f);
    if (u_lobe < r) return bsdf_make_delta(reflect_z(wo), mat_specular_reflectance(m), 1.0);
    return bsdf_make_delta(-wo, mat_specular_transmittance(m), 1.0);
}

// ---- roughdielectric (Walter et al. 2007, VNDF sampling; both sides) ----

SHARED_FN vec3 roughdielectric_eval_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    pdf = 0.0;
    float co = wo.z;
    float ci = wi.z;
    if (abs(co) < MF_MIN_COS || ci == 0.0) return vec3(0.0);
    float eta = mat_eta(m);
    bool refl = co * ci > 0.0;
    // IOR of wi's side over wo's side (used for transmission only).
    float eta_path = co > 0.0 ? eta : 1.0 / eta;
    vec3 h = refl ? wo + wi : wo + wi * eta_path;
    float l2 = dot(h, h);
    if (!(l2 > 1e-30)) return vec3(0.0);
    h = h * inversesqrt(l2);
    if (h.z < 0.0) h = -h;
    float doh = dot(wo, h);
    float dih = dot(wi, h);
    // Each direction must see the front of the facet from its own side.
    if (doh * co <= 0.0 || dih * ci <= 0.0) return vec3(0.0);
    Microfacet d = mat_microfacet(m);
    float dh = mf_D(d, h);
    if (dh <= 0.0) return vec3(0.0);
    float f = fresnel_dielectric_r(doh, eta);
    float g = mf_G1(d, wo, h) * mf_G1(d, wi, h);
    float pdf_h = mf_pdf_visible(d, co > 0.0 ? wo : -wo, h);
    if (refl) {
        pdf = f * pdf_h / (4.0 * abs(dih));
        float v = f * dh * g / (4.0 * abs(co));
        return mat_specular_reflectance(m) * v;
    }
    // Transmission. (doh + eta_path dih)^2 = |wo + eta_path wi|^2 = l2 exactly.
    pdf = (1.0 - f) * pdf_h * eta_path * eta_path * abs(dih) / l2;
    // Walter's eta_path^2 cancels against the radiance scaling 1/eta_path^2.
    float v = (1.0 - f) * dh * g * abs(doh * dih) / (abs(co) * l2);
    return mat_specular_transmittance(m) * v;
}

SHARED_FN BsdfSample roughdielectric_sample(GpuMaterial m, vec3 albedo, vec3 wo, float u_lobe, vec2 u) {
    float co = wo.z;
    if (abs(co) < MF_MIN_COS) return bsdf_sample_none();
    vec3 h = mf_sample_visible(mat_microfacet(m), co > 0.0 ? wo : -wo, u);
    float cos_t;
    float eta_it;
    float eta_ti;
    float f = fresnel_dielectric(dot(wo, h), mat_eta(m), cos_t, eta_it, eta_ti);
    vec3 wi;
    float eta_out = 1.0;
    if (u_lobe < f) {
        wi = reflect_about(wo, h);
        if (wi.z * co <= 0.0) return bsdf_sample_none();
    } else {
        wi = refract_about(wo, h, cos_t, eta_ti);
        if (wi.z * co >= 0.0) return bsdf_sample_none();
        eta_out = eta_it;
    }
    float pdf;
    vec3 fv = roughdielectric_eval_pdf(m, albedo, wo, wi, pdf);
    return bsdf_make_sample(wi, fv, pdf, LOBE_G, eta_out);
}

// ---- plastic family: shared pieces ----

// Mitsuba's specular_sampling_weight: mean specular / (mean diffuse + mean
// specular), from the material's constants (a textured material should carry
// its texture's mean in reflectance.rgb, as Mitsuba takes the texture mean).
SHARED_FN float plastic_specular_weight(GpuMaterial m) {
    float d_mean = mean3(vec3(m.reflectance));
    float s_mean = mean3(mat_specular_reflectance(m));
    float sum = d_mean + s_mean;
    return sum > 0.0 ? s_mean / sum : 0.5;
}

// Probability of sampling the coat, given the coat's reflectance at wo.
SHARED_FN float plastic_prob_specular(float coat_reflectance, float sw) {
    float ps = coat_reflectance * sw;
    float pd = (1.0 - coat_reflectance) * (1.0 - sw);
    float t = ps + pd;
    if (t > 0.0) return ps / t;
    return coat_reflectance > 0.5 ? 1.0 : 0.0;
}

// Diffuse base seen through the coat: reflectance divided by the share that
// is not trapped by internal reflection (Mitsuba's `nonlinear` option keeps
// the colour shift of repeated bounces).
SHARED_FN vec3 plastic_base(GpuMaterial m, vec3 albedo, float internal_reflectance) {
    if (m.k.w != 0.0) {
        vec3 denom = max(vec3(1.0) - albedo * internal_reflectance, vec3(1e-4));
        return albedo / denom;
    }
    float denom = 1.0 - internal_reflectance;
    return albedo / max(denom, float(1e-4));
}

// ---- plastic (smooth coat: delta lobe S + diffuse base lobe D) ----

SHARED_FN vec3 plastic_eval_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    pdf = 0.0;
    if (wo.z <= 0.0 || wi.z <= 0.0) return vec3(0.0);
    float eta = mat_eta(m);
    float f_in = fresnel_dielectric_r(wo.z, eta);
    float f_out = fresnel_dielectric_r(wi.z, eta);
    float p_spec = plastic_prob_specular(f_in, plastic_specular_weight(m));
    float cos_pdf = wi.z * VKM_INV_PI;
    pdf = (1.0 - p_spec) * cos_pdf;
    vec3 base = plastic_base(m, albedo, fresnel_diffuse_reflectance(1.0 / eta));
    float s = (1.0 - f_in) * (1.0 - f_out) / (eta * eta) * cos_pdf;
    return base * s;
}

SHARED_FN BsdfSample plastic_sample(GpuMaterial m, vec3 albedo, vec3 wo, float u_lobe, vec2 u) {
    if (wo.z <= 0.0) return bsdf_sample_none();
    float f_in = fresnel_dielectric_r(wo.z, mat_eta(m));
    float p_spec = plastic_prob_specular(f_in, plastic_specular_weight(m));
    if (u_lobe < p_spec) {
        float s = f_in / p_spec;
        return bsdf_make_delta(reflect_z(wo), mat_specular_reflectance(m) * s, 1.0);
    }
    vec3 wi = square_to_cosine_hemisphere(u);
    float pdf;
    vec3 f = plastic_eval_pdf(m, albedo, wo, wi, pdf);
    return bsdf_make_sample(wi, f, pdf, LOBE_D, 1.0);
}

// ---- roughplastic (microfacet coat lobe G + diffuse base lobe D) ----
//
// Mitsuba precomputes, per material, the rough coat's transmittance T(mu)
// (64 nodes in mu) and the base's internal reflectance. Here the host stores
// them in the material's own block (GpuMaterial.model0..2):
// model0.xyzw, model1.xyzw, model2.xyz = T at
// sqrt(mu) = 0, 0.1, ..., 1 (linear in between), model2.w =
// 1 + internal reflectance (0 = not prepared). roughplastic_prepare() fills
// them; an unprepared material falls back to the smooth-coat values
// 1 - F(mu) and the diffuse Fresnel reflectance.

const int RP_TABLE_NODES = 11;

SHARED_FN float rp_table_get(GpuMaterial m, int i) {
    if (i < 4) return m.model0[i];
    if (i < 8) return m.model1[i - 4];
    return m.model2[i - 8];
}

SHARED_FN bool roughplastic_prepared(GpuMaterial m) { return m.model2.w >= 1.0; }

SHARED_FN Microfacet roughplastic_microfacet(GpuMaterial m) {
    return microfacet_make(m.header.w, m.reflectance.w, m.reflectance.w);  // isotropic, as Mitsuba
}

SHARED_FN float roughplastic_transmittance(GpuMaterial m, float mu) {
    if (!roughplastic_prepared(m)) return 1.0 - fresnel_dielectric_r(mu, mat_eta(m));
    float s = sqrt(saturate(mu)) * float(RP_TABLE_NODES - 1);
    int i = min(int(s), RP_TABLE_NODES - 2);
    float t = s - float(i);
    return mix(rp_table_get(m, i), rp_table_get(m, i + 1), t);
}

SHARED_FN float roughplastic_internal_reflectance(GpuMaterial m) {
    if (!roughplastic_prepared(m)) return fresnel_diffuse_reflectance(1.0 / mat_eta(m));
    return m.model2.w - 1.0;
}

SHARED_FN vec3 roughplastic_eval_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    pdf = 0.0;
    if (wo.z < MF_MIN_COS || wi.z <= 0.0) return vec3(0.0);
    float eta = mat_eta(m);
    float t_in = roughplastic_transmittance(m, wo.z);
    float t_out = roughplastic_transmittance(m, wi.z);
    float p_spec = plastic_prob_specular(1.0 - t_in, plastic_specular_weight(m));
    vec3 result = vec3(0.0);
    float p = 0.0;
    vec3 h = wo + wi;
    float l2 = dot(h, h);
    if (l2 > 1e-30) {
        h = h * inversesqrt(l2);
        Microfacet d = roughplastic_microfacet(m);
        float dh = mf_D(d, h);
        if (dh > 0.0) {
            float spec_pdf = mf_G1(d, wo, h) * dh / (4.0 * wo.z);  // D_wo(h) / (4 wi.h)
            float v = fresnel_dielectric_r(dot(wo, h), eta) * mf_G1(d, wi, h) * spec_pdf;
            result += mat_specular_reflectance(m) * v;
            p += p_spec * spec_pdf;
        }
    }
    float cos_pdf = wi.z * VKM_INV_PI;
    vec3 base = plastic_base(m, albedo, roughplastic_internal_reflectance(m));
    float s = t_in * t_out / (eta * eta) * cos_pdf;
    result += base * s;
    p += (1.0 - p_spec) * cos_pdf;
    pdf = p;
    return result;
}

SHARED_FN BsdfSample roughplastic_sample(GpuMaterial m, vec3 albedo, vec3 wo, float u_lobe, vec2 u) {
    if (wo.z < MF_MIN_COS) return bsdf_sample_none();
    float t_in = roughplastic_transmittance(m, wo.z);
    float p_spec = plastic_prob_specular(1.0 - t_in, plastic_specular_weight(m));
    vec3 wi;
    uint lobe;
    if (u_lobe < p_spec) {
        wi = reflect_about(wo, mf_sample_visible(roughplastic_microfacet(m), wo, u));
        lobe = LOBE_G;
    } else {
        wi = square_to_cosine_hemisphere(u);
        lobe = LOBE_D;
    }
    if (wi.z <= 0.0) return bsdf_sample_none();
    float pdf;
    vec3 f = roughplastic_eval_pdf(m, albedo, wo, wi, pdf);
    return bsdf_make_sample(wi, f, pdf, lobe, 1.0);
}

// Rough-interface averages by a midpoint rule over the VNDF's unit square:
// the energy transmitted (reflected) from direction (sqrt(1-mu^2), 0, mu) into
// the other (same) side, single scattering, Smith masking of the exit.
SHARED_FN float rough_interface_average(Microfacet d, float eta, float mu, int n, bool transmitted) {
    vec3 w = vec3(safe_sqrt(1.0 - mu * mu), 0.0, mu);
    float sum = 0.0;
    for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
            vec2 u = vec2((float(i) + 0.5) / float(n), (float(j) + 0.5) / float(n));
            vec3 h = mf_sample_visible(d, w, u);
            float cos_t;
            float eta_it;
            float eta_ti;
            float f = fresnel_dielectric(dot(w, h), eta, cos_t, eta_it, eta_ti);
            if (transmitted) {
                vec3 wt = refract_about(w, h, cos_t, eta_ti);
                if (wt.z < 0.0) sum += (1.0 - f) * mf_G1(d, wt, h);
            } else {
                vec3 wr = reflect_about(w, h);
                if (wr.z > 0.0) sum += f * mf_G1(d, wr, h);
            }
        }
    }
    return sum / float(n * n);
}

// Fills the roughplastic tables (see above); the host calls it once per
// material when it packs GpuMaterial. A few 10^5 VNDF samples.
SHARED_FN GpuMaterial roughplastic_prepare(GpuMaterial m) {
    if (m.header.x != MAT_ROUGHPLASTIC) return m;
    Microfacet d = roughplastic_microfacet(m);
    float eta = mat_eta(m);
    GpuMaterial r = m;
    for (int i = 0; i < RP_TABLE_NODES; ++i) {
        float s = float(i) / float(RP_TABLE_NODES - 1);
        float t = rough_interface_average(d, eta, max(s * s, float(1e-6)), 64, true);
        if (i < 4) {
            r.model0[i] = t;
        } else if (i < 8) {
            r.model1[i - 4] = t;
        } else {
            r.model2[i - 8] = t;
        }
    }
    // Internal reflectance: 2 int_0^1 R(mu, 1/eta) mu dmu = int_0^1 R(sqrt(x)) dx.
    const int NX = 32;
    float sum = 0.0;
    for (int k = 0; k < NX; ++k) {
        float x = (float(k) + 0.5) / float(NX);
        sum += rough_interface_average(d, 1.0 / eta, sqrt(x), 48, false);
    }
    r.model2.w = 1.0 + saturate(sum / float(NX));
    return r;
}

// ---- principled (Mitsuba 3's `principled`) ----
//
// Lobes: diffuse (Disney diffuse + retro-reflection + sheen; D), the main GGX
// specular reflection (G), the GTR1 clearcoat (G) and the GGX specular
// transmission (G). Selection on the outside as Mitsuba with unit sampling
// rates: specular 1, clearcoat clearcoat/4, diffuse (1-metallic)(1-spec_trans),
// normalized; the specular lobe then reflects with probability
// 1 - bsdf (1 - F(wo.m)) and transmits otherwise. Inside: the specular lobe
// only, reflecting with probability F. Deviation from Mitsuba: the sheen is
// weighted by the diffuse weight (1-metallic)(1-spec_trans) (Mitsuba:
// 1-metallic), so that it belongs to the diffuse component, is covered by its
// sampling, and the docs/descriptor.md §2 flag rule (D iff the diffuse weight > 0) holds.

struct Principled {
    vec3 base;
    float metallic;
    float roughness;
    float spec_tint;
    float sheen;
    float sheen_tint;
    float clearcoat;
    float eta;
    float w_brdf;  // (1 - metallic)(1 - spec_trans): the diffuse weight
    float w_bsdf;  // (1 - metallic) spec_trans: the transmission weight
    float alpha_cc;
    Microfacet d;
    float p_diffuse;  // selection probabilities on the outside
    float p_clearcoat;
    float p_specular;
};

SHARED_FN Principled principled_params(GpuMaterial m, vec3 albedo) {
    Principled p;
    p.base = albedo;
    p.metallic = saturate(m.model0.x);
    p.roughness = saturate(m.model0.y);
    p.spec_tint = saturate(m.model0.w);
    float anisotropic = saturate(m.model1.x);
    p.sheen = max(m.model1.y, float(0.0));
    p.sheen_tint = saturate(m.model1.z);
    p.clearcoat = max(m.model1.w, float(0.0));
    float clearcoat_gloss = saturate(m.model2.x);
    float spec_trans = saturate(m.model2.y);
    p.eta = m.model2.z > 0.0 ? m.model2.z : 1.5;
    p.w_brdf = (1.0 - p.metallic) * (1.0 - spec_trans);
    p.w_bsdf = (1.0 - p.metallic) * spec_trans;
    // Mitsuba's calc_dist_params: alpha = roughness^2, stretched by the aspect.
    float r2 = p.roughness * p.roughness;
    float aspect = sqrt(1.0 - 0.9 * anisotropic);
    p.d = microfacet_make(MF_GGX, max(float(0.001), r2 / aspect), max(float(0.001), r2 * aspect));
    p.alpha_cc = mix(float(0.1), float(0.001), clearcoat_gloss);
    float w_cc = p.clearcoat > 0.0 ? 0.25 * p.clearcoat : 0.0;
    float total = 1.0 + w_cc + p.w_brdf;
    p.p_specular = 1.0 / total;
    p.p_clearcoat = w_cc / total;
    p.p_diffuse = p.w_brdf / total;
    return p;
}

SHARED_FN bool principled_transmissive(GpuMaterial m) {
    return (1.0 - saturate(m.model0.x)) * saturate(m.model2.y) > 0.0;
}

// Reflectance of the main specular lobe on the outside: dielectric Fresnel
// blended with Schlick terms for metallic and the tinted specular.
SHARED_FN vec3 principled_fresnel_front(Principled p, float f_dielectric, float cos_theta_i) {
    vec3 f = vec3((1.0 - p.metallic) * (1.0 - p.spec_tint) * f_dielectric);
    if (p.metallic > 0.0) f += p.metallic * schlick_fresnel3(p.base, cos_theta_i, p.eta);
    if (p.spec_tint > 0.0) {
        float lum = bsdf_luminance(p.base);
        vec3 c_tint = lum > 0.0 ? p.base / lum : vec3(1.0);
        float eta_it = cos_theta_i >= 0.0 ? p.eta : 1.0 / p.eta;
        vec3 r0 = c_tint * schlick_r0_eta(eta_it);
        float w = (1.0 - p.metallic) * p.spec_tint;
        f += w * schlick_fresnel3(r0, cos_theta_i, p.eta);
    }
    return f;
}

SHARED_FN vec3 principled_eval_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    pdf = 0.0;
    float co = wo.z;
    float ci = wi.z;
    if (abs(co) < MF_MIN_COS || ci == 0.0) return vec3(0.0);
    Principled p = principled_params(m, albedo);
    bool front = co > 0.0;
    bool refl = co * ci > 0.0;
    if (!(front && refl) && p.w_bsdf <= 0.0) return vec3(0.0);
    float eta_path = front ? p.eta : 1.0 / p.eta;
    vec3 h = refl ? wo + wi : wo + wi * eta_path;
    float l2 = dot(h, h);
    if (!(l2 > 1e-30)) return vec3(0.0);
    h = h * inversesqrt(l2);
    if (h.z < 0.0) h = -h;
    float doh = dot(wo, h);
    float dih = dot(wi, h);
    vec3 result = vec3(0.0);
    float pr = 0.0;

    // Main specular lobe (reflection and transmission).
    if (doh * co > 0.0 && dih * ci > 0.0) {
        float dh = mf_D(p.d, h);
        if (dh > 0.0) {
            float f_d = fresnel_dielectric_r(doh, p.eta);
            float g = mf_G1(p.d, wo, h) * mf_G1(p.d, wi, h);
            float pdf_h = mf_pdf_visible(p.d, front ? wo : -wo, h);
            float p_sel = front ? p.p_specular : 1.0;
            float p_refl = front ? 1.0 - p.w_bsdf * (1.0 - f_d) : f_d;
            if (refl) {
                vec3 fr = front ? principled_fresnel_front(p, f_d, doh) : vec3(p.w_bsdf * f_d);
                float v = dh * g / (4.0 * abs(co));
                result += fr * v;
                pr += p_sel * p_refl * pdf_h / (4.0 * abs(dih));
            } else {
                float v = p.w_bsdf * (1.0 - f_d) * dh * g * abs(doh * dih) / (abs(co) * l2);
                result += sqrt(p.base) * v;
                pr += p_sel * (1.0 - p_refl) * pdf_h * eta_path * eta_path * abs(dih) / l2;
            }
        }
    }

    if (front && refl) {
        // Diffuse: Burley's diffuse with retro-reflection, plus sheen.
        if (p.w_brdf > 0.0) {
            float fo = schlick_weight(ci);
            float fi = schlick_weight(co);
            float f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
            float cos_d = dot(h, wi);
            float rr = 2.0 * p.roughness * cos_d * cos_d;
            float f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
            float s = p.w_brdf * ci * VKM_INV_PI * (f_diff + f_retro);
            result += p.base * s;
            if (p.sheen > 0.0) {
                float lum = bsdf_luminance(p.base);
                vec3 c_tint = lum > 0.0 ? p.base / lum : vec3(1.0);
                vec3 c_sheen = mix(vec3(1.0), c_tint, p.sheen_tint);
                float sh = p.sheen * p.w_brdf * schlick_weight(abs(cos_d)) * ci;
                result += c_sheen * sh;
            }
            pr += p.p_diffuse * ci * VKM_INV_PI;
        }
        // Clearcoat: GTR1 normals, Schlick Fresnel (R0 0.04, eta 1.5), GGX
        // masking with alpha 0.25 (Burley's choices, as Mitsuba).
        if (p.clearcoat > 0.0) {
            float dcc = gtr1_D(p.alpha_cc, h);
            if (dcc > 0.0) {
                float fcc = schlick_fresnel(0.04, dih, 1.5);
                float gcc = smith_ggx1(wo, h, 0.25) * smith_ggx1(wi, h, 0.25);
                float v = 0.25 * p.clearcoat * fcc * dcc * gcc / (4.0 * co);
                result += vec3(v);
                pr += p.p_clearcoat * dcc * h.z / (4.0 * dih);
            }
        }
    }
    pdf = pr;
    return result;
}

SHARED_FN BsdfSample principled_sample(GpuMaterial m, vec3 albedo, vec3 wo, float u_lobe, vec2 u) {
    float co = wo.z;
    if (abs(co) < MF_MIN_COS) return bsdf_sample_none();
    Principled p = principled_params(m, albedo);
    bool front = co > 0.0;
    if (!front && p.w_bsdf <= 0.0) return bsdf_sample_none();
    float p_diff = front ? p.p_diffuse : 0.0;
    float p_cc = front ? p.p_clearcoat : 0.0;
    float p_spec = front ? p.p_specular : 1.0;
    vec3 wi;
    uint lobe = LOBE_G;
    float eta_out = 1.0;
    if (u_lobe < p_diff) {
        wi = square_to_cosine_hemisphere(u);
        lobe = LOBE_D;
    } else if (u_lobe < p_diff + p_cc) {
        wi = reflect_about(wo, gtr1_sample(p.alpha_cc, u));
        if (wi.z <= 0.0) return bsdf_sample_none();
    } else {
        // Reuse the rest of u_lobe for the reflect / transmit choice.
        float uu = min((u_lobe - p_diff - p_cc) / p_spec, float(0.99999994));
        vec3 h = mf_sample_visible(p.d, front ? wo : -wo, u);
        float cos_t;
        float eta_it;
        float eta_ti;
        float f_d = fresnel_dielectric(dot(wo, h), p.eta, cos_t, eta_it, eta_ti);
        float p_refl = front ? 1.0 - p.w_bsdf * (1.0 - f_d) : f_d;
        if (uu < p_refl) {
            wi = reflect_about(wo, h);
            if (wi.z * co <= 0.0) return bsdf_sample_none();
        } else {
            wi = refract_about(wo, h, cos_t, eta_ti);
            if (wi.z * co >= 0.0) return bsdf_sample_none();
            eta_out = eta_it;
        }
    }
    float pdf;
    vec3 f = principled_eval_pdf(m, albedo, wo, wi, pdf);
    return bsdf_make_sample(wi, f, pdf, lobe, eta_out);
}

// ---- roughdiffuse (Oren-Nayar, as Mitsuba 0.6's `roughdiffuse`) ----
//
// Oren and Nayar's (1994) model of a surface of Lambertian V-cavities, in full:
// single scattering with the C1..C3 terms plus the interreflection term C4, as
// Mitsuba evaluates it by default (its `use_fast_approx` drops C3 and C4; the
// loader warns and renders the full model). The roughness is Mitsuba's alpha,
// a Beckmann-style RMS slope, converted to the Oren-Nayar angular deviation
// sigma = alpha / sqrt(2); alpha 0 is Lambertian. Sampling is cosine-weighted.
// The full model is not exactly energy conserving: with albedo 1 it reflects
// up to about 1.7 % more than it receives at grazing incidence (measured:
// tests/test_bsdf.cpp, white furnace), as Mitsuba's does.
// Mitsuba declares the one component glossy reflection, so its samples are of
// class G (docs/descriptor.md §2 reduces Mitsuba's flags; shared/materials.h).

struct RoughDiffuse {
    float sigma2;  // sigma^2, the variance of the facet angles
};

SHARED_FN RoughDiffuse roughdiffuse_params(GpuMaterial m) {
    RoughDiffuse p;
    float sigma = m.reflectance.w * 0.70710678;  // alpha (GpuMaterial.reflectance.w) / sqrt(2)
    p.sigma2 = sigma * sigma;
    return p;
}

SHARED_FN vec3 roughdiffuse_eval_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    pdf = 0.0;
    if (wo.z <= 0.0 || wi.z <= 0.0) return vec3(0.0);
    RoughDiffuse p = roughdiffuse_params(m);
    float sin_o = safe_sqrt(1.0 - wo.z * wo.z);
    float sin_i = safe_sqrt(1.0 - wi.z * wi.z);
    // cos(phi_o - phi_i); 0 where either azimuth is undefined (at the normal).
    float cos_phi = 0.0;
    if (sin_o > 1e-4 && sin_i > 1e-4)
        cos_phi = clamp((wo.x * wi.x + wo.y * wi.y) / (sin_o * sin_i), float(-1.0), float(1.0));
    float theta_o = acos(min(wo.z, float(1.0)));
    float theta_i = acos(min(wi.z, float(1.0)));
    float a = max(theta_o, theta_i);  // Oren-Nayar's alpha and beta: the larger and the smaller angle
    float b = min(theta_o, theta_i);
    float sin_a = wo.z > wi.z ? sin_i : sin_o;
    float sin_b = wo.z > wi.z ? sin_o : sin_i;
    float tan_b = wo.z > wi.z ? sin_o / wo.z : sin_i / wi.z;
    float s2 = p.sigma2;
    float t1 = s2 / (s2 + 0.09);
    float t2 = (4.0 * VKM_INV_PI * VKM_INV_PI) * a * b;
    float t3 = 2.0 * b * VKM_INV_PI;
    float c1 = 1.0 - 0.5 * s2 / (s2 + 0.33);
    float c2 = 0.45 * t1 * (cos_phi > 0.0 ? sin_a : sin_a - t3 * t3 * t3);
    float c3 = 0.125 * t1 * t2 * t2;
    float c4 = 0.17 * s2 / (s2 + 0.13);
    // tan((a + b) / 2) by the half-angle formula.
    float tan_half = (sin_a + sin_b) / (safe_sqrt(1.0 - sin_a * sin_a) + safe_sqrt(1.0 - sin_b * sin_b));
    float single_scattering = c1 + cos_phi * c2 * tan_b + (1.0 - abs(cos_phi)) * c3 * tan_half;
    float interreflection = c4 * (1.0 - cos_phi * t3 * t3);
    pdf = wi.z * VKM_INV_PI;
    // Far from the normal on very rough surfaces (alpha above about 1) the
    // fitted C2 term turns the single scattering negative; a BSDF cannot be.
    return max(albedo * single_scattering + albedo * albedo * interreflection, vec3(0.0)) * pdf;
}

SHARED_FN BsdfSample roughdiffuse_sample(GpuMaterial m, vec3 albedo, vec3 wo, float u_lobe, vec2 u) {
    vec3 wi;
    if (!cosine_weighted_wi(wo, u, wi)) return bsdf_sample_none();
    float pdf;
    vec3 f = roughdiffuse_eval_pdf(m, albedo, wo, wi, pdf);
    return bsdf_make_sample(wi, f, pdf, LOBE_G, 1.0);
}

// ---- blendbsdf (Mitsuba's `blendbsdf`) ----
// Not a BSDF of its own: the path tracer resolves a blend to one of its components at each
// hit, before any query (blend_resolve in pathtrace.comp), so the dispatch never reaches
// these; a blend queried directly has no lobe and reflects nothing.

SHARED_FN vec3 blendbsdf_eval_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    return delta_only_eval_pdf(pdf);
}

SHARED_FN BsdfSample blendbsdf_sample(GpuMaterial m, vec3 albedo, vec3 wo, float u_lobe, vec2 u) {
    return bsdf_sample_none();
}

// ---- dispatch ----

// The lobe classes the material can sample (lobes.glsl, docs/descriptor.md §2).
SHARED_FN uint bsdf_lobe_flags(GpuMaterial m) {
    return material_lobe_flags(m.header.x, m.model0.x, m.model2.y);
}

// Delta-only: every lobe is S (conductor, dielectric, thindielectric).
SHARED_FN bool bsdf_is_delta_only(GpuMaterial m) { return bsdf_lobe_flags(m) == LOBE_BIT_S; }

// docs/descriptor.md §2: the NEE end-vertex lobe. D if the BSDF advertises any diffuse
// component, G if it is non-delta without one, LOBE_NONE if delta-only (no NEE).
SHARED_FN uint bsdf_nee_lobe(GpuMaterial m) {
    uint f = bsdf_lobe_flags(m);
    if ((f & LOBE_BIT_D) != 0u) return LOBE_D;
    if ((f & LOBE_BIT_G) != 0u) return LOBE_G;
    return LOBE_NONE;
}

// Whether the material lets light through (and so sees both sides itself):
// the table's VKM_MATF_TRANSMISSIVE, and for principled its spec_trans.
SHARED_FN bool bsdf_is_transmissive(GpuMaterial m) {
    uint t = m.header.x;
    if ((material_flags(t) & VKM_MATF_TRANSMISSIVE) == 0u) return false;
    if (t == MAT_PRINCIPLED) return principled_transmissive(m);
    return true;
}

// Mitsuba's `twosided`: a back-side query is answered by the front side with
// both directions mirrored.
SHARED_FN bool bsdf_mirrors(GpuMaterial m, vec3 wo) {
    return (m.header.y & 1u) != 0u && wo.z < 0.0 && !bsdf_is_transmissive(m);
}

SHARED_FN vec3 flip_z(vec3 v) { return vec3(v.x, v.y, -v.z); }

// f |cos wi| and pdf of the non-delta components, without the twosided rule:
// <name>_eval_pdf of the material table's row (shared/materials.h), if its
// features are compiled in.
SHARED_FN vec3 bsdf_eval_pdf_front(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    pdf = 0.0;
    uint t = m.header.x;
#define VKM_X(code, NAME, Name, name, features, lobes, flags) \
    if (t == (code)) {                                         \
        if (features_on(features)) return name##_eval_pdf(m, albedo, wo, wi, pdf); \
        return vec3(0.0);                                      \
    }
    VKM_MATERIALS(VKM_X)
#undef VKM_X
    return vec3(0.0);  // unknown types and compiled-out families
}

SHARED_FN vec3 bsdf_eval_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi, OUT(float) pdf) {
    if (bsdf_mirrors(m, wo)) return bsdf_eval_pdf_front(m, albedo, flip_z(wo), flip_z(wi), pdf);
    return bsdf_eval_pdf_front(m, albedo, wo, wi, pdf);
}

SHARED_FN vec3 bsdf_eval(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi) {
    float pdf;
    return bsdf_eval_pdf(m, albedo, wo, wi, pdf);
}

SHARED_FN float bsdf_pdf(GpuMaterial m, vec3 albedo, vec3 wo, vec3 wi) {
    float pdf;
    bsdf_eval_pdf(m, albedo, wo, wi, pdf);
    return pdf;
}

// One sample of <name>_sample of the material table's row, if its features are compiled in.
SHARED_FN BsdfSample bsdf_sample(GpuMaterial m, vec3 albedo, vec3 wo, float u_lobe, vec2 u) {
    bool mirror = bsdf_mirrors(m, wo);
    vec3 w = mirror ? flip_z(wo) : wo;
    uint t = m.header.x;
    BsdfSample s = bsdf_sample_none();
#define VKM_X(code, NAME, Name, name, features, lobes, flags) \
    if (t == (code)) {                                         \
        if (features_on(features)) s = name##_sample(m, albedo, w, u_lobe, u); \
    }
    VKM_MATERIALS(VKM_X)
#undef VKM_X
    if (mirror && s.ok) s.wi = flip_z(s.wi);
    return s;
}

#ifdef __cplusplus
}  // namespace vkmech::shader
#pragma GCC diagnostic pop
#endif

#endif
