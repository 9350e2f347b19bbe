// The BSDF library (shaders/sampling.glsl, fresnel.glsl, microfacet.glsl,
// bsdf.glsl) compiled as C++: the very functions the path tracer runs.
// Specifications pinned here (docs/architecture.md, "Tests are specifications"):
//  - special functions, Fresnel, D and G1 against independent double-precision
//    references and analytic integrals;
//  - chi-square goodness of fit of bsdf_sample's directions against bsdf_pdf
//    for every non-delta component (pbrt-v4's method: expected counts by
//    integrating the pdf, sparse cells pooled, Sidak-corrected significance),
//    on a lobe-adapted theta/phi grid whose horizon is a cell boundary;
//  - weight == bsdf_eval / bsdf_pdf for non-delta samples, the pdf's total mass
//    equals the share of non-delta samples, the eval has no support outside
//    the pdf's (integral of eval == mean weight);
//  - white furnaces, hard numerical cases, and the docs/descriptor.md §2 NEE lobe per material.
#include "bsdf.glsl"
#include "chi2.hpp"

#include <doctest/doctest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <complex>
#include <cstdint>
#include <functional>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

using namespace vkmech::shader;
using vkmech::gpu::GpuMaterial;

namespace {

using vkmech::testing::gamma_q;
using vkmech::testing::TestRng;

constexpr double kPi = 3.14159265358979323846;

// ---------------------------------------------------------------------------
// Deterministic random numbers (splitmix64), floats in [0, 1) like the GPU's.

// ---------------------------------------------------------------------------
// Materials, packed as the host packs them (see GpuMaterial in shared/types.h).
GpuMaterial base_material(uint32_t type) {
    GpuMaterial m{};
    m.header = glm::uvec4(type, 0u, 0u, MF_GGX);
    m.reflectance = glm::vec4(0.5f, 0.5f, 0.5f, 0.1f);
    m.specular_reflectance = glm::vec4(1.0f, 1.0f, 1.0f, 0.1f);
    m.specular_transmittance = glm::vec4(1.0f, 1.0f, 1.0f, 1.5f);
    m.eta = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
    m.k = glm::vec4(1.0f, 1.0f, 1.0f, 0.0f);
    m.model0 = glm::vec4(0.0f, 0.5f, 0.5f, 0.0f);
    m.model1 = glm::vec4(0.0f);
    m.model2 = glm::vec4(0.0f, 0.0f, 1.5f, 0.0f);
    return m;
}
void set_albedo(GpuMaterial& m, glm::vec3 a) { m.reflectance = glm::vec4(a, m.reflectance.w); }
void set_alpha(GpuMaterial& m, uint32_t dist, float au, float av) {
    m.header.w = dist;
    m.reflectance.w = au;
    m.specular_reflectance.w = av;
}
void set_ior(GpuMaterial& m, float int_ior, float ext_ior = 1.0f) {
    m.specular_transmittance.w = int_ior;
    m.eta.w = ext_ior;
}

GpuMaterial mat_diffuse(glm::vec3 albedo, bool twosided = false) {
    GpuMaterial m = base_material(MAT_DIFFUSE);
    set_albedo(m, albedo);
    m.header.y = twosided ? 1u : 0u;
    return m;
}
// Au-like complex IOR so that F varies with angle and channel.
const glm::vec3 kGoldEta(0.143f, 0.374f, 1.442f);
const glm::vec3 kGoldK(3.983f, 2.385f, 1.603f);
GpuMaterial mat_conductor(glm::vec3 eta, glm::vec3 k) {
    GpuMaterial m = base_material(MAT_CONDUCTOR);
    m.eta = glm::vec4(eta, 1.0f);
    m.k = glm::vec4(k, 0.0f);
    return m;
}
GpuMaterial mat_roughconductor(uint32_t dist, float au, float av, glm::vec3 eta = kGoldEta, glm::vec3 k = kGoldK) {
    GpuMaterial m = mat_conductor(eta, k);
    m.header.x = MAT_ROUGHCONDUCTOR;
    set_alpha(m, dist, au, av);
    return m;
}
GpuMaterial mat_dielectric(uint32_t type, float int_ior, float ext_ior = 1.0f) {
    GpuMaterial m = base_material(type);
    set_ior(m, int_ior, ext_ior);
    return m;
}
GpuMaterial mat_roughdielectric(uint32_t dist, float au, float av, float int_ior) {
    GpuMaterial m = mat_dielectric(MAT_ROUGHDIELECTRIC, int_ior);
    set_alpha(m, dist, au, av);
    return m;
}
GpuMaterial mat_plastic(glm::vec3 albedo, float int_ior, bool nonlinear) {
    GpuMaterial m = base_material(MAT_PLASTIC);
    set_albedo(m, albedo);
    set_ior(m, int_ior);
    m.k.w = nonlinear ? 1.0f : 0.0f;
    return m;
}
GpuMaterial mat_roughplastic(uint32_t dist, float alpha, glm::vec3 albedo, float int_ior, bool nonlinear,
                             bool prepare = true) {
    GpuMaterial m = mat_plastic(albedo, int_ior, nonlinear);
    m.header.x = MAT_ROUGHPLASTIC;
    set_alpha(m, dist, alpha, alpha);
    return prepare ? roughplastic_prepare(m) : m;
}
GpuMaterial mat_roughdiffuse(glm::vec3 albedo, float alpha) {
    GpuMaterial m = base_material(MAT_ROUGHDIFFUSE);
    set_albedo(m, albedo);
    m.reflectance.w = alpha;
    return m;
}
struct PrincipledParams {
    float metallic = 0.0f, roughness = 0.5f, spec_tint = 0.0f, anisotropic = 0.0f, sheen = 0.0f, sheen_tint = 0.0f,
          clearcoat = 0.0f, clearcoat_gloss = 0.0f, spec_trans = 0.0f, eta = 1.5f;
};
GpuMaterial mat_principled(const PrincipledParams& p, glm::vec3 base) {
    GpuMaterial m = base_material(MAT_PRINCIPLED);
    set_albedo(m, base);
    float r = (p.eta - 1.0f) / (p.eta + 1.0f);
    m.model0 = glm::vec4(p.metallic, p.roughness, r * r / 0.08f, p.spec_tint);
    m.model1 = glm::vec4(p.anisotropic, p.sheen, p.sheen_tint, p.clearcoat);
    m.model2 = glm::vec4(p.clearcoat_gloss, p.spec_trans, p.eta, 0.0f);
    return m;
}

glm::vec3 albedo_of(const GpuMaterial& m) { return glm::vec3(m.reflectance); }

// A unit direction with the given cosine to the normal and azimuth.
glm::vec3 dir_cos(double cos_theta, double phi = 0.7) {
    double s = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
    return glm::vec3(static_cast<float>(s * std::cos(phi)), static_cast<float>(s * std::sin(phi)),
                     static_cast<float>(cos_theta));
}

bool finite_nonneg(float x) { return std::isfinite(x) && x >= 0.0f; }
bool finite_nonneg(glm::vec3 v) { return finite_nonneg(v.x) && finite_nonneg(v.y) && finite_nonneg(v.z); }
double lum(glm::vec3 c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

// ---------------------------------------------------------------------------
// Independent double-precision references.

double ref_fresnel_dielectric(double cos_i, double eta) {
    if (cos_i < 0.0) {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    double sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin_t2 >= 1.0) return 1.0;
    double cos_t = std::sqrt(1.0 - sin_t2);
    double rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    double rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

double ref_fresnel_conductor(double cos_i, double eta, double k) {
    std::complex<double> n(eta, k);
    double sin2 = 1.0 - cos_i * cos_i;
    std::complex<double> root = std::sqrt(n * n - sin2);
    std::complex<double> rs = (cos_i - root) / (cos_i + root);
    std::complex<double> rp = (n * n * cos_i - root) / (n * n * cos_i + root);
    return 0.5 * (std::norm(rs) + std::norm(rp));
}

double ref_D(uint32_t type, double au, double av, double mx, double my, double mz) {
    if (mz <= 0.0) return 0.0;
    double z2 = mz * mz;
    double e = (mx * mx / (au * au) + my * my / (av * av)) / z2;
    if (type == MF_BECKMANN) return std::exp(-e) / (kPi * au * av * z2 * z2);
    double q = 1.0 + e;
    return 1.0 / (kPi * au * av * z2 * z2 * q * q);
}

double ref_G1(uint32_t type, double au, double av, double vx, double vy, double vz) {
    double tan2 = (au * au * vx * vx + av * av * vy * vy) / (vz * vz);  // alpha^2 tan^2
    if (tan2 == 0.0) return 1.0;
    if (type == MF_GGX) return 2.0 / (1.0 + std::sqrt(1.0 + tan2));
    double a = 1.0 / std::sqrt(tan2);
    double lambda = (std::exp(-a * a) / (a * std::sqrt(kPi)) - std::erfc(a)) / 2.0;
    return 1.0 / (1.0 + lambda);
}

// ---------------------------------------------------------------------------
// The chi-square grid: theta split at the horizon into two halves, each warped
// logarithmically around a lobe centre (cells of size ~w near it, growing
// away from it); phi warped around the lobes' azimuth. The horizon is a cell
// boundary, so the pdf's jump there never lies inside a cell.
struct Warp1D {
    // Cells [0, n_lo) cover [lo, c], cells [n_lo, n) cover [c, hi]: the centre
    // (where the warp has a kink) is a cell boundary. Within a side, the
    // coordinate v = sign(x - c) log(1 + |x - c| / w) is linear in u.
    double lo = 0, hi = 1, c = 0, w = 1, glo = 0, ghi = 1;
    int n = 1, n_lo = 0;
    Warp1D() = default;
    Warp1D(double lo_, double hi_, double c_, double w_, int n_)
        : lo(lo_), hi(hi_), c(std::clamp(c_, lo_, hi_)), w(w_), n(n_) {
        glo = g(lo);
        ghi = g(hi);
        n_lo = int(std::lround(n * (-glo) / (ghi - glo)));
        if (c > lo) n_lo = std::max(n_lo, 1);
        if (c < hi) n_lo = std::min(n_lo, n - 1);
    }
    double g(double x) const {
        double d = x - c;
        return (d < 0 ? -1.0 : 1.0) * std::log1p(std::abs(d) / w);
    }
    // Position t in [0, 1] inside cell `cell`.
    double v_of(int cell, double t) const {
        double u = (cell + t) / n;
        if (cell < n_lo) return glo + u * n / n_lo * (0.0 - glo);
        return (u * n - n_lo) / (n - n_lo) * ghi;
    }
    double dv_du(int cell) const { return cell < n_lo ? -glo * n / n_lo : ghi * n / (n - n_lo); }
    double x_of(int cell, double t) const {
        double v = v_of(cell, t);
        return c + (v < 0 ? -1.0 : 1.0) * w * std::expm1(std::abs(v));
    }
    double dx_du(int cell, double t) const { return dv_du(cell) * w * std::exp(std::abs(v_of(cell, t))); }
    int cell_of(double x) const {
        double v = g(x);
        double u = v < 0 ? (v - glo) / (0.0 - glo) * n_lo / n : (n_lo + v / ghi * (n - n_lo)) / n;
        return std::clamp(int(u * n), 0, n - 1);
    }
};

struct Chi2Case {
    std::string name;
    GpuMaterial m;
    glm::vec3 wo;
    double width;  // angular lobe width for the grid (about alpha)
};

struct Chi2Outcome {
    std::string name;
    double chi2 = 0, pval = 0;
    int dof = 0;
    std::string failure;  // structural failure (zero-expected cell hit, dof too low)
    double pdf_mass = 0;  // integral of bsdf_pdf over the sphere
    double ok_share = 0;  // share of samples that are non-delta and valid
    double eval_integral = 0, mean_weight = 0, weight_sd = 0;  // luminance
    long weight_mismatch = 0, pdf_mismatch = 0, support_violation = 0, bad_values = 0;
    long checked = 0;
};

constexpr int kThetaHalf = 20, kPhi = 48;

Chi2Outcome run_chi2(const Chi2Case& cs, int n_samples, uint64_t seed) {
    Chi2Outcome out;
    out.name = cs.name;
    const GpuMaterial& m = cs.m;
    glm::vec3 albedo = albedo_of(m);
    glm::vec3 wo = cs.wo;

    // Lobe centres: the mirror direction and, where it exists, the refracted
    // one. Widths: a facet tilt of alpha moves the mirror direction by 2 alpha
    // in theta but only by 2 alpha cos(theta_o) across the plane of incidence
    // (a grazing lobe is a thin sliver); the refracted lobe is narrower.
    double th_r = std::acos(std::clamp(double(wo.z), -1.0, 1.0));
    double w = std::max(cs.width, 0.002);
    double cos_o = std::abs(double(wo.z)), sin_o = std::sqrt(std::max(0.0, 1.0 - cos_o * cos_o));
    double w_phi = std::min(2.0 * w * cos_o / std::max(sin_o, 1e-3), 4.0);
    double c_up = 0.0, c_dn = kPi, w_up = w, w_dn = w;
    (th_r <= kPi / 2 ? c_up : c_dn) = th_r;
    float cos_t, eta_it, eta_ti;
    float f = fresnel_dielectric(wo.z, mat_eta(m), cos_t, eta_it, eta_ti);
    if (f < 1.0f && m.header.x != MAT_DIFFUSE) {
        double th_t = std::acos(std::clamp(double(cos_t), -1.0, 1.0));
        double w_t = std::max(0.3 * w, 0.002);
        (th_t <= kPi / 2 ? c_up : c_dn) = th_t;
        (th_t <= kPi / 2 ? w_up : w_dn) = w_t;
        w_phi = std::min(w_phi, w_t / std::max(std::sin(th_t), 1e-3));
    }
    w_phi = std::max(w_phi, 1e-5);
    double phi_c = std::atan2(-double(wo.y), -double(wo.x));
    Warp1D up(0.0, kPi / 2, c_up, w_up, kThetaHalf), dn(kPi / 2, kPi, c_dn, w_dn, kThetaHalf),
        ph(phi_c - kPi, phi_c + kPi, phi_c, w_phi, kPhi);

    const int n_cells = 2 * kThetaHalf * kPhi;
    std::vector<double> expected(n_cells, 0.0), observed(n_cells, 0.0);

    // Expected: adaptive Simpson's rule per cell in the warped coordinates
    // (pbrt-v4 integrates adaptively too). Each cell evaluates its own nodes,
    // so the warps' kinks on cell boundaries do not leak into a neighbour; a
    // region is split while its 3x3 and 5x5 estimates differ by more than a
    // small fraction of the cell's sampling noise, which catches the pdf's
    // jumps inside cells (facet visibility, total internal reflection).
    double pdf_mass = 0, eval_mass = 0;
    struct PE {
        double p = 0, e = 0;
    };
    for (int half = 0; half < 2; ++half) {
        const Warp1D& wt = half == 0 ? up : dn;
        for (int ct = 0; ct < kThetaHalf; ++ct) {
            for (int cp = 0; cp < kPhi; ++cp) {
                // Integrand at cell-local (t, tp) in [0, 1]^2, per unit local area.
                auto node = [&](double t, double tp) {
                    double th = wt.x_of(ct, t);
                    double th_eval = std::clamp(th, wt.lo + 1e-7, wt.hi - 1e-7);  // this half's side of the horizon
                    double phi = ph.x_of(cp, tp);
                    double jac = wt.dx_du(ct, t) * std::sin(th) * ph.dx_du(cp, tp) / (double(kThetaHalf) * kPhi);
                    glm::vec3 wi =
                        glm::normalize(glm::vec3(float(std::sin(th_eval) * std::cos(phi)),
                                                 float(std::sin(th_eval) * std::sin(phi)), float(std::cos(th_eval))));
                    float p = bsdf_pdf(m, albedo, wo, wi);
                    glm::vec3 e = bsdf_eval(m, albedo, wo, wi);
                    if (!std::isfinite(p) || p < 0.0f || !finite_nonneg(e)) ++out.bad_values;
                    if (p == 0.0f && (e.x > 0.0f || e.y > 0.0f || e.z > 0.0f)) ++out.support_violation;
                    return PE{double(p) * jac, lum(e) * jac};
                };
                // Simpson over [t0, t0 + h] x [p0, p0 + h] from the 3x3 nodes f.
                auto simpson3 = [](const PE f[3][3], double h) {
                    const double w[3] = {1, 4, 1};
                    PE r;
                    for (int i = 0; i < 3; ++i)
                        for (int j = 0; j < 3; ++j) {
                            r.p += w[i] * w[j] * f[i][j].p;
                            r.e += w[i] * w[j] * f[i][j].e;
                        }
                    r.p *= h * h / 36.0;
                    r.e *= h * h / 36.0;
                    return r;
                };
                std::function<PE(double, double, double, const PE(*)[3], int)> adapt =
                    [&](double t0, double p0, double h, const PE f[3][3], int depth) -> PE {
                    PE g[5][5];
                    for (int i = 0; i < 5; ++i)
                        for (int j = 0; j < 5; ++j)
                            g[i][j] =
                                (i % 2 == 0 && j % 2 == 0) ? f[i / 2][j / 2] : node(t0 + h * i / 4.0, p0 + h * j / 4.0);
                    PE coarse = simpson3(f, h), fine;
                    PE q[2][2][3][3];
                    for (int a = 0; a < 2; ++a)
                        for (int b = 0; b < 2; ++b) {
                            for (int i = 0; i < 3; ++i)
                                for (int j = 0; j < 3; ++j) q[a][b][i][j] = g[2 * a + i][2 * b + j];
                            PE s3 = simpson3(q[a][b], h / 2);
                            fine.p += s3.p;
                            fine.e += s3.e;
                        }
                    double noise = std::sqrt(std::max(std::abs(fine.p), 1.0 / n_samples) / n_samples);
                    if (depth >= 6 || std::abs(fine.p - coarse.p) <= 0.02 * noise) return fine;
                    PE sum;
                    for (int a = 0; a < 2; ++a)
                        for (int b = 0; b < 2; ++b) {
                            PE r = adapt(t0 + a * h / 2, p0 + b * h / 2, h / 2, q[a][b], depth + 1);
                            sum.p += r.p;
                            sum.e += r.e;
                        }
                    return sum;
                };
                PE f0[3][3];
                for (int i = 0; i < 3; ++i)
                    for (int j = 0; j < 3; ++j) f0[i][j] = node(i / 2.0, j / 2.0);
                PE r = adapt(0.0, 0.0, 1.0, f0, 0);
                expected[(half * kThetaHalf + ct) * kPhi + cp] = r.p;
                pdf_mass += r.p;
                eval_mass += r.e;
            }
        }
    }
    out.pdf_mass = pdf_mass;
    out.eval_integral = eval_mass;

    // Observed.
    TestRng rng(seed);
    long ok = 0;
    double wsum = 0, wsum2 = 0;
    auto cell_of = [&](glm::vec3 d) {
        // atan2, not acos(z): float z near +-1 cannot resolve angles below ~3e-4.
        double th = std::atan2(std::hypot(double(d.x), double(d.y)), double(d.z));
        double phi = std::atan2(double(d.y), double(d.x));
        while (phi < ph.lo) phi += 2 * kPi;
        while (phi >= ph.hi) phi -= 2 * kPi;
        int it = th <= kPi / 2 ? up.cell_of(th) : kThetaHalf + dn.cell_of(th);
        int ip = ph.cell_of(phi);
        return it * kPhi + ip;
    };
    for (int i = 0; i < n_samples; ++i) {
        float ul = rng.next();
        glm::vec2 u(rng.next(), rng.next());
        BsdfSample s = bsdf_sample(m, albedo, wo, ul, u);
        if (!s.ok || s.lobe == LOBE_S) continue;
        if (!finite_nonneg(s.weight) || !(s.pdf > 0.0f) || !std::isfinite(s.pdf)) {
            ++out.bad_values;
            continue;
        }
        ++ok;
        double wl = lum(s.weight);
        wsum += wl;
        wsum2 += wl * wl;
        observed[cell_of(s.wi)] += 1.0;
        if (i % 8 == 0) {  // (2): weight and pdf against the public eval / pdf
            ++out.checked;
            glm::vec3 e = bsdf_eval(m, albedo, wo, s.wi);
            float p = bsdf_pdf(m, albedo, wo, s.wi);
            if (!(p > 0.0f)) {
                ++out.pdf_mismatch;
                continue;
            }
            glm::vec3 r = e / p;
            float tol = 1e-3f * std::max({r.x, r.y, r.z}) + 1e-7f;
            if (std::abs(s.weight.x - r.x) > tol || std::abs(s.weight.y - r.y) > tol ||
                std::abs(s.weight.z - r.z) > tol)
                ++out.weight_mismatch;
            if (std::abs(s.pdf - p) > 1e-3f * p) ++out.pdf_mismatch;
        }
    }
    out.ok_share = double(ok) / n_samples;
    out.mean_weight = wsum / n_samples;
    double var = wsum2 / n_samples - out.mean_weight * out.mean_weight;
    out.weight_sd = std::sqrt(std::max(var, 0.0) / n_samples);

    // pbrt-v4's pooling: cells sorted by expected count; sparse ones pooled.
    for (double& e : expected) e *= n_samples;
    std::vector<int> order(n_cells);
    for (int i = 0; i < n_cells; ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](int a, int b) { return expected[a] < expected[b]; });
    double pooled_obs = 0, pooled_exp = 0, chsq = 0;
    int dof = 0;
    for (int idx : order) {
        if (expected[idx] == 0.0) {
            if (observed[idx] > n_samples * 1e-5) out.failure = "samples in a cell of zero expected count";
        } else if (expected[idx] < 5.0 || (pooled_exp > 0.0 && pooled_exp < 5.0)) {
            pooled_obs += observed[idx];
            pooled_exp += expected[idx];
        } else {
            double d = observed[idx] - expected[idx];
            chsq += d * d / expected[idx];
            ++dof;
        }
    }
    if (pooled_exp > 0.0 || pooled_obs > 0.0) {
        double d = pooled_obs - pooled_exp;
        chsq += d * d / std::max(pooled_exp, 1e-300);
        ++dof;
    }
    dof -= 1;
    out.chi2 = chsq;
    out.dof = dof;
    if (dof < 5) {
        out.failure = "too few degrees of freedom (" + std::to_string(dof) + ")";
        out.pval = 0.0;
    } else {
        out.pval = gamma_q(0.5 * dof, 0.5 * chsq);
    }
    return out;
}

// Runs the cases on all cores; results in case order.
std::vector<Chi2Outcome> run_chi2_all(const std::vector<Chi2Case>& cases, int n_samples, uint64_t seed_base) {
    std::vector<Chi2Outcome> results(cases.size());
    std::atomic<size_t> next{0};
    unsigned n_threads = std::max(1u, std::thread::hardware_concurrency());
    std::vector<std::thread> pool;
    for (unsigned t = 0; t < n_threads; ++t) {
        pool.emplace_back([&]() {
            for (size_t i = next++; i < cases.size(); i = next++)
                results[i] = run_chi2(cases[i], n_samples, seed_base + 7919 * i);
        });
    }
    for (auto& th : pool) th.join();
    return results;
}

// ---------------------------------------------------------------------------
// The chi-square case lists (every non-delta component, docs/descriptor.md §2 materials).
const double kCosines[] = {1.0, 0.5, 0.1, 0.01};
const float kAlphas[] = {0.01f, 0.1f, 0.5f, 1.0f};
const char* dist_name(uint32_t d) { return d == MF_GGX ? "ggx" : "beckmann"; }

std::vector<Chi2Case> cases_diffuse_plastic() {
    std::vector<Chi2Case> cs;
    for (double c : kCosines) {
        cs.push_back({"diffuse cos " + std::to_string(c), mat_diffuse(glm::vec3(0.8f, 0.5f, 0.2f)), dir_cos(c), 2.0});
        cs.push_back({"plastic cos " + std::to_string(c), mat_plastic(glm::vec3(0.6f, 0.4f, 0.2f), 1.5f, c < 0.2),
                      dir_cos(c), 2.0});
    }
    cs.push_back({"diffuse twosided back", mat_diffuse(glm::vec3(0.5f), true), dir_cos(-0.5), 2.0});
    cs.push_back({"plastic twosided back",
                  [] {
                      GpuMaterial m = mat_plastic(glm::vec3(0.3f), 1.9f, false);
                      m.header.y = 1u;
                      return m;
                  }(),
                  dir_cos(-0.3), 2.0});
    return cs;
}

std::vector<Chi2Case> cases_roughconductor() {
    std::vector<Chi2Case> cs;
    for (uint32_t dist : {MF_BECKMANN, MF_GGX}) {
        for (bool aniso : {false, true}) {
            for (float a : kAlphas) {
                for (double c : kCosines) {
                    float av = aniso ? 0.3f * a : a;
                    std::string name = std::string("roughconductor ") + dist_name(dist) + (aniso ? " aniso" : " iso") +
                                       " alpha " + std::to_string(a) + " cos " + std::to_string(c);
                    cs.push_back({name, mat_roughconductor(dist, a, av), dir_cos(c), std::min(a, av)});
                }
            }
        }
    }
    return cs;
}

std::vector<Chi2Case> cases_roughdielectric() {
    std::vector<Chi2Case> cs;
    const double wos[] = {1.0, 0.5, 0.1, 0.01, -1.0, -0.9, -0.5, -0.1};
    for (uint32_t dist : {MF_BECKMANN, MF_GGX}) {
        for (float a : kAlphas) {
            for (double c : wos) {
                std::string name = std::string("roughdielectric ") + dist_name(dist) + " eta 1.5 alpha " +
                                   std::to_string(a) + " cos " + std::to_string(c);
                cs.push_back({name, mat_roughdielectric(dist, a, a, 1.5f), dir_cos(c), a});
            }
        }
    }
    cs.push_back({"roughdielectric ggx aniso out", mat_roughdielectric(MF_GGX, 0.3f, 0.08f, 1.5f), dir_cos(0.5), 0.08});
    cs.push_back({"roughdielectric beckmann aniso in", mat_roughdielectric(MF_BECKMANN, 0.3f, 0.08f, 1.5f),
                  dir_cos(-0.7), 0.08});
    cs.push_back({"roughdielectric eta 2.5 out", mat_roughdielectric(MF_GGX, 0.3f, 0.3f, 2.5f), dir_cos(0.5), 0.3});
    cs.push_back(
        {"roughdielectric eta 2.5 in", mat_roughdielectric(MF_BECKMANN, 0.3f, 0.3f, 2.5f), dir_cos(-0.95), 0.3});
    cs.push_back({"roughdielectric eta 1/1.33 (ext_ior 1.33)",
                  [] {
                      GpuMaterial m = mat_roughdielectric(MF_GGX, 0.2f, 0.2f, 1.0f);
                      set_ior(m, 1.0f, 1.33f);
                      return m;
                  }(),
                  dir_cos(0.6), 0.2});
    return cs;
}

std::vector<Chi2Case> cases_roughplastic(bool prepare = true) {
    std::vector<Chi2Case> cs;
    for (uint32_t dist : {MF_BECKMANN, MF_GGX}) {
        for (float a : kAlphas) {
            GpuMaterial m = mat_roughplastic(dist, a, glm::vec3(0.6f, 0.3f, 0.1f), 1.5f, a > 0.3f, prepare);
            for (double c : kCosines) {
                std::string name = std::string("roughplastic ") + dist_name(dist) + " alpha " + std::to_string(a) +
                                   " cos " + std::to_string(c);
                cs.push_back({name, m, dir_cos(c), a});
            }
        }
    }
    cs.push_back({"roughplastic unprepared", mat_roughplastic(MF_GGX, 0.2f, glm::vec3(0.5f), 1.5f, false, false),
                  dir_cos(0.4), 0.2});
    return cs;
}

std::vector<Chi2Case> cases_principled() {
    std::vector<Chi2Case> cs;
    const float roughness[] = {0.1f, 0.316f, 0.707f, 1.0f};  // alpha 0.01, 0.1, 0.5, 1
    glm::vec3 base(0.8f, 0.4f, 0.2f);
    for (float r : roughness) {
        float a = std::max(0.001f, r * r);
        for (double c : kCosines) {
            std::string sfx = " roughness " + std::to_string(r) + " cos " + std::to_string(c);
            PrincipledParams p;
            p.roughness = r;
            cs.push_back({"principled plain" + sfx, mat_principled(p, base), dir_cos(c), a});
            PrincipledParams q = p;
            q.clearcoat = 1.0f;
            q.clearcoat_gloss = 0.5f;
            q.sheen = 0.5f;
            q.sheen_tint = 0.5f;
            q.spec_tint = 0.5f;
            cs.push_back({"principled clearcoat+sheen" + sfx, mat_principled(q, base), dir_cos(c), std::min(a, 0.05f)});
            PrincipledParams mt = p;
            mt.metallic = 1.0f;
            mt.anisotropic = 0.8f;
            cs.push_back({"principled metallic aniso" + sfx, mat_principled(mt, base), dir_cos(c), a * 0.45});
        }
        const double wos[] = {1.0, 0.5, 0.1, 0.01, -0.9, -0.5, -0.1};
        for (double c : wos) {
            PrincipledParams t;
            t.roughness = r;
            t.spec_trans = 0.8f;
            t.metallic = 0.1f;
            t.clearcoat = 0.5f;
            cs.push_back({"principled spec_trans roughness " + std::to_string(r) + " cos " + std::to_string(c),
                          mat_principled(t, base), dir_cos(c), a});
        }
    }
    PrincipledParams two;
    two.metallic = 0.5f;
    GpuMaterial m2 = mat_principled(two, base);
    m2.header.y = 1u;
    cs.push_back({"principled twosided back", m2, dir_cos(-0.6), 0.25});
    return cs;
}

std::vector<Chi2Case> cases_roughdiffuse() {
    std::vector<Chi2Case> cs;
    for (float a : {0.0f, 0.2f, 0.6f, 1.5f})
        for (double c : kCosines)
            cs.push_back({"roughdiffuse alpha " + std::to_string(a) + " cos " + std::to_string(c),
                          mat_roughdiffuse(glm::vec3(0.7f, 0.5f, 0.3f), a), dir_cos(c), 2.0});
    GpuMaterial back = mat_roughdiffuse(glm::vec3(0.4f), 0.5f);
    back.header.y = 1u;
    cs.push_back({"roughdiffuse twosided back", back, dir_cos(-0.4), 2.0});
    return cs;
}

size_t total_chi2_tests() {
    return cases_diffuse_plastic().size() + cases_roughconductor().size() + cases_roughdielectric().size() +
           cases_roughplastic(false).size() + cases_principled().size() + cases_roughdiffuse().size();
}

// Checks one batch against the Sidak-corrected level (0.01 over all chi-square tests).
void check_chi2(const std::vector<Chi2Case>& cases, int n_samples, uint64_t seed) {
    static const size_t n_tests = total_chi2_tests();
    const double alpha = 1.0 - std::pow(1.0 - 0.01, 1.0 / double(n_tests));
    auto results = run_chi2_all(cases, n_samples, seed);
    for (const Chi2Outcome& r : results) {
        INFO(r.name << ": chi2 " << r.chi2 << " dof " << r.dof << " p " << r.pval << " (level " << alpha
                    << "), pdf mass " << r.pdf_mass << " vs non-delta share " << r.ok_share << ", eval integral "
                    << r.eval_integral << " vs mean weight " << r.mean_weight << " +- " << r.weight_sd);
        CHECK(r.failure == "");
        CHECK(r.pval >= alpha);
        CHECK(r.bad_values == 0);
        CHECK(r.support_violation == 0);  // eval > 0 only where the pdf is > 0
        CHECK(r.checked > 0);
        CHECK(r.weight_mismatch == 0);  // (2) weight == eval / pdf
        CHECK(r.pdf_mismatch == 0);     //     pdf == bsdf_pdf
        // (3) the pdf's mass is at most 1 and equals the share of non-delta samples.
        CHECK(r.pdf_mass <= 1.0 + 2e-3);
        double share_sd = std::sqrt(r.ok_share * (1.0 - r.ok_share) / n_samples);
        CHECK(std::abs(r.pdf_mass - r.ok_share) <= 5.0 * share_sd + 3e-3);
        // Integral of eval == E[weight] (no eval outside the sampled support).
        CHECK(std::abs(r.eval_integral - r.mean_weight) <= 5.0 * r.weight_sd + 5e-3 * r.mean_weight + 1e-4);
    }
}

constexpr int kChi2Samples = 100000;

}  // namespace

// ===========================================================================

TEST_CASE("bsdf: erf and erfc and erfinv agree with the C library") {
    for (double xd = -4.0; xd <= 4.0; xd += 0.01) {
        double x = double(float(xd));  // the float argument the shader sees
        INFO("x = " << x);
        CHECK(std::abs(vkm_erf(float(x)) - std::erf(x)) < 3e-7);
        CHECK(std::abs(vkm_erfc(float(x)) - std::erfc(x)) <= 2e-6 * std::erfc(x) + 1e-7 * (x < 0));  // float exp(-x^2)
    }
    for (double y = -0.999999; y < 1.0; y += 0.000731) {
        double x = vkm_erfinv(float(y));
        INFO("y = " << y);
        // Through the double-precision erf: relative error in 1 - |y| (the tail) and in y.
        CHECK(std::abs(std::erf(x) - float(y)) <=
              2e-6 * (1.0 - std::abs(double(float(y)))) + 2e-7 * std::abs(y) + 1e-9);
    }
}

TEST_CASE("bsdf: warps stay on their domain with the stated normalisation") {
    TestRng rng(3);
    for (int i = 0; i < 100000; ++i) {
        glm::vec2 u(rng.next(), rng.next());
        glm::vec3 s = square_to_uniform_sphere(u);
        glm::vec3 h = square_to_cosine_hemisphere(u);
        glm::vec2 d = square_to_uniform_disk_concentric(u);
        glm::vec2 p = square_to_uniform_disk(u);
        CHECK(std::abs(glm::length(s) - 1.0f) < 1e-5f);
        CHECK(std::abs(glm::length(h) - 1.0f) < 1e-5f);
        CHECK(h.z >= 0.0f);
        CHECK(glm::length(d) <= 1.0f + 1e-6f);
        CHECK(glm::length(p) <= 1.0f + 1e-6f);
    }
    // Cosine hemisphere: E[z] = 2/3 and E[z^2] = 1/2 for density cos/pi.
    double m1 = 0, m2 = 0;
    const int n = 400000;
    for (int i = 0; i < n; ++i) {
        glm::vec3 h = square_to_cosine_hemisphere(glm::vec2(rng.next(), rng.next()));
        m1 += h.z;
        m2 += h.z * h.z;
    }
    CHECK(m1 / n == doctest::Approx(2.0 / 3.0).epsilon(2e-3));
    CHECK(m2 / n == doctest::Approx(0.5).epsilon(3e-3));
    CHECK(square_to_cosine_hemisphere_pdf(glm::vec3(0, 0, 1)) == doctest::Approx(1.0 / kPi));
    CHECK(square_to_uniform_sphere_pdf() == doctest::Approx(1.0 / (4.0 * kPi)));
}

TEST_CASE("bsdf: dielectric and conductor Fresnel match the textbook formulas") {
    for (float eta : {1.0001f, 1.33f, 1.5f, 2.5f, 0.6f}) {
        for (double c = -1.0; c <= 1.0; c += 0.0125) {
            float cos_t, eta_it, eta_ti;
            float f = fresnel_dielectric(float(c), eta, cos_t, eta_it, eta_ti);
            INFO("eta " << eta << " cos " << c);
            // Float rounding is amplified next to the critical angle (dF/dcos is infinite there).
            double eta_side = c >= 0 ? double(eta) : 1.0 / eta;
            double sin_t2 = (1 - c * c) / (eta_side * eta_side);
            double tol = std::abs(1.0 - sin_t2) < 1e-2 ? 1e-3 : 2e-5;
            CHECK(std::abs(f - ref_fresnel_dielectric(c, eta)) < tol);
            if (f < 1.0f && c != 0.0) {  // Snell and the sign convention of cos_theta_t
                double sin_i = std::sqrt(1 - c * c), sin_t = std::sqrt(std::max(0.0, 1.0 - double(cos_t) * cos_t));
                CHECK(sin_i == doctest::Approx(eta_it * sin_t).epsilon(1e-4));
                CHECK(cos_t * c <= 0.0f);
                CHECK(eta_it * eta_ti == doctest::Approx(1.0));
            }
        }
    }
    // Total internal reflection from the inside beyond the critical angle.
    CHECK(fresnel_dielectric_r(-0.5f, 2.5f) == 1.0f);
    CHECK(fresnel_dielectric_r(-0.01f, 1.0001f) == 1.0f);
    // Conductor: against complex arithmetic; k = 0 is the dielectric.
    for (double c = 0.0; c <= 1.0; c += 0.01) {
        for (auto nk : {std::pair{0.143, 3.983}, {1.442, 1.603}, {0.0, 1.0}, {2.0, 0.0}, {0.2, 0.0}}) {
            double n = nk.first, k = nk.second;
            INFO("cos " << c << " eta " << n << " k " << k);
            double ref = c == 0.0 ? 1.0 : ref_fresnel_conductor(c, n, k);
            CHECK(std::abs(fresnel_conductor1(float(c), float(n), float(k)) - ref) < 2e-5);
        }
        CHECK(fresnel_conductor1(float(c), 0.0f, 1.0f) == doctest::Approx(1.0).epsilon(1e-6));  // Mitsuba "none"
    }
    // Diffuse Fresnel reflectance: the fits against 2 int F(mu) mu dmu.
    for (double eta : {1.1, 1.33, 1.5, 2.0, 1 / 1.33, 1 / 1.5}) {
        double sum = 0;
        const int n = 20000;
        for (int i = 0; i < n; ++i) {
            double mu = (i + 0.5) / n;
            sum += ref_fresnel_dielectric(mu, eta) * 2 * mu / n;
        }
        INFO("eta " << eta);
        CHECK(fresnel_diffuse_reflectance(float(eta)) == doctest::Approx(sum).epsilon(0.01));
    }
}

TEST_CASE("bsdf: microfacet D and G1 match references - D is normalised and G1 is Smith's") {
    for (uint32_t type : {MF_BECKMANN, MF_GGX}) {
        for (auto a2 : {std::pair{0.01f, 0.01f}, {0.1f, 0.1f}, {0.5f, 0.2f}, {1.0f, 1.0f}, {0.05f, 0.6f}}) {
            float au = a2.first, av = a2.second;
            Microfacet d = microfacet_make(type, au, av);
            INFO(std::string(dist_name(type)) << " alpha " << au << ", " << av);
            // Point values against the references.
            TestRng rng(11);
            for (int i = 0; i < 2000; ++i) {
                glm::vec3 m = square_to_uniform_hemisphere(glm::vec2(rng.next(), rng.next()));
                double r = ref_D(type, au, av, m.x, m.y, m.z);
                float v = mf_D(d, m);
                if (r * m.z > 1e-18) CHECK(v == doctest::Approx(r).epsilon(1e-4));
                double g = ref_G1(type, au, av, m.x, m.y, m.z);
                CHECK(std::abs(mf_G1(d, m, glm::vec3(0, 0, 1)) - g) < 2e-6);
            }
            // Integrals on a theta grid refined around the pole (double sums).
            const int nth = 600, nph = 256;
            Warp1D wt(0.0, kPi / 2, 0.0, 0.5 * std::min(au, av), nth);
            double norm = 0;
            const double vcos[] = {0.95, 0.5, 0.1, 0.02};
            double proj[4] = {0, 0, 0, 0};
            glm::vec3 vs[4];
            for (int k = 0; k < 4; ++k) vs[k] = dir_cos(vcos[k], 0.4);
            for (int a = 0; a < nth; ++a) {
                double th = wt.x_of(a, 0.5), jt = wt.dx_du(a, 0.5) * std::sin(th) / nth;
                for (int b = 0; b < nph; ++b) {
                    double phi = 2 * kPi * (b + 0.5) / nph;
                    glm::vec3 m(float(std::sin(th) * std::cos(phi)), float(std::sin(th) * std::sin(phi)),
                                float(std::cos(th)));
                    double dm = mf_D(d, m) * jt * 2 * kPi / nph;
                    norm += dm * m.z;
                    for (int k = 0; k < 4; ++k) proj[k] += dm * std::max(0.0f, glm::dot(vs[k], m));
                }
            }
            CHECK(norm == doctest::Approx(1.0).epsilon(2e-3));  // int D cos = 1
            for (int k = 0; k < 4; ++k) {
                // Smith: int D max(0, v.m) dm = v.z / G1(v): the VNDF integrates to 1.
                INFO("v.z = " << vcos[k]);
                CHECK(proj[k] * mf_G1(d, vs[k], glm::vec3(0, 0, 1)) / vs[k].z == doctest::Approx(1.0).epsilon(3e-3));
            }
        }
    }
    // GTR1 (clearcoat) normalisation.
    for (float a : {0.001f, 0.01f, 0.1f}) {
        const int nth = 4000;
        Warp1D wt(0.0, kPi / 2, 0.0, 0.5 * a, nth);
        double norm = 0;
        for (int i = 0; i < nth; ++i) {
            double th = wt.x_of(i, 0.5);
            glm::vec3 m(float(std::sin(th)), 0.0f, float(std::cos(th)));
            norm += gtr1_D(a, m) * m.z * std::sin(th) * wt.dx_du(i, 0.5) / nth * 2 * kPi;
        }
        INFO("gtr1 alpha " << a);
        CHECK(norm == doctest::Approx(1.0).epsilon(2e-3));
    }
}

TEST_CASE("bsdf chi-square: diffuse and plastic (non-delta part)") {
    check_chi2(cases_diffuse_plastic(), kChi2Samples, 1000);
}

TEST_CASE("bsdf chi-square: roughconductor (beckmann and ggx - iso and aniso)") {
    check_chi2(cases_roughconductor(), kChi2Samples, 2000);
}

TEST_CASE("bsdf chi-square: roughdielectric (both sides - TIR region)") {
    check_chi2(cases_roughdielectric(), kChi2Samples, 3000);
}

TEST_CASE("bsdf chi-square: roughplastic") { check_chi2(cases_roughplastic(), kChi2Samples, 4000); }

TEST_CASE("bsdf chi-square: roughdiffuse (Oren-Nayar)") { check_chi2(cases_roughdiffuse(), kChi2Samples, 6000); }

TEST_CASE("bsdf chi-square: principled (diffuse + specular + clearcoat + spec_trans)") {
    check_chi2(cases_principled(), kChi2Samples, 5000);
}

// ---------------------------------------------------------------------------

namespace {
struct FurnaceStats {
    double mean = 0, sd = 0, max = 0;
    long ok = 0;
};
// Mean (over all samples, failures count 0) of lum(weight) * scale(sample).
FurnaceStats furnace(const GpuMaterial& m, glm::vec3 wo, int n, uint64_t seed,
                     const std::function<double(const BsdfSample&)>& scale = nullptr) {
    TestRng rng(seed);
    double s = 0, s2 = 0;
    FurnaceStats st;
    for (int i = 0; i < n; ++i) {
        float ul = rng.next();
        BsdfSample b = bsdf_sample(m, albedo_of(m), wo, ul, glm::vec2(rng.next(), rng.next()));
        if (!b.ok) continue;
        ++st.ok;
        double v = lum(b.weight) * (scale ? scale(b) : 1.0);
        s += v;
        s2 += v * v;
        st.max = std::max(st.max, v);
    }
    st.mean = s / n;
    st.sd = std::sqrt(std::max(0.0, s2 / n - st.mean * st.mean) / n);
    return st;
}
double undo_radiance_scaling(const BsdfSample& b) { return double(b.eta) * b.eta; }
}  // namespace

TEST_CASE("bsdf: white furnace") {
    SUBCASE("albedo-1 diffuse reflects exactly 1") {
        for (double c : {1.0, 0.5, 0.01}) {
            GpuMaterial m = mat_diffuse(glm::vec3(1.0f));
            TestRng rng(5);
            for (int i = 0; i < 10000; ++i) {
                BsdfSample b =
                    bsdf_sample(m, glm::vec3(1.0f), dir_cos(c), rng.next(), glm::vec2(rng.next(), rng.next()));
                REQUIRE(b.ok);
                CHECK(std::abs(b.weight.x - 1.0f) < 1e-6f);
                CHECK(b.lobe == LOBE_D);
            }
        }
    }
    SUBCASE("F = 1 conductor (eta 0, k 1): smooth reflects exactly 1, rough <= 1 and > 0.9 at alpha 0.1") {
        GpuMaterial smooth = mat_conductor(glm::vec3(0.0f), glm::vec3(1.0f));
        for (double c : {1.0, 0.3, 1e-4}) {
            BsdfSample b = bsdf_sample(smooth, glm::vec3(1.0f), dir_cos(c), 0.5f, glm::vec2(0.5f));
            REQUIRE(b.ok);
            CHECK(b.lobe == LOBE_S);
            CHECK(b.pdf == 0.0f);
            CHECK(std::abs(b.weight.x - 1.0f) < 1e-6f);
            CHECK(b.wi.z == doctest::Approx(c));
        }
        for (uint32_t dist : {MF_BECKMANN, MF_GGX}) {
            for (float a : {0.001f, 0.1f, 0.5f, 1.0f}) {
                GpuMaterial m = mat_roughconductor(dist, a, a, glm::vec3(0.0f), glm::vec3(1.0f));
                for (double c : {1.0, 0.5}) {
                    FurnaceStats st = furnace(m, dir_cos(c), 200000, 17);
                    INFO(std::string(dist_name(dist))
                         << " alpha " << a << " cos " << c << ": " << st.mean << " +- " << st.sd);
                    CHECK(st.max <= 1.0 + 1e-5);  // each weight is G1(wi) <= 1
                    CHECK(st.mean <= 1.0 + 3 * st.sd + 1e-6);
                    if (a <= 0.1f) CHECK(st.mean > 0.9);
                }
            }
        }
    }
    SUBCASE("dielectric: reflectance + transmittance (without 1/eta^2) == 1 per sample") {
        for (float eta : {1.0001f, 1.5f, 2.5f}) {
            GpuMaterial m = mat_dielectric(MAT_DIELECTRIC, eta);
            for (double c : {1.0, 0.7, 0.1, 1e-4, -1e-4, -0.3, -0.95}) {
                TestRng rng(23);
                long n_t = 0;
                for (int i = 0; i < 4000; ++i) {
                    BsdfSample b = bsdf_sample(m, glm::vec3(1.0f), dir_cos(c), rng.next(), glm::vec2(0.3f, 0.3f));
                    REQUIRE(b.ok);
                    CHECK(b.lobe == LOBE_S);
                    bool transmitted = b.wi.z * float(c) < 0.0f;
                    n_t += transmitted;
                    double w = b.weight.x * (transmitted ? double(b.eta) * b.eta : 1.0);
                    CHECK(w == doctest::Approx(1.0).epsilon(1e-5));
                    if (!transmitted) CHECK(b.eta == 1.0f);
                }
                // Fresnel-proportional choice: the transmitted share is 1 - F.
                double t_ref = 1.0 - ref_fresnel_dielectric(c, eta);
                INFO("eta " << eta << " cos " << c);
                CHECK(std::abs(n_t / 4000.0 - t_ref) < 5 * std::sqrt(t_ref * (1 - t_ref) / 4000) + 1e-3);
            }
        }
        GpuMaterial thin = mat_dielectric(MAT_THINDIELECTRIC, 1.5f);
        FurnaceStats st = furnace(thin, dir_cos(0.3), 100000, 3);
        CHECK(st.mean == doctest::Approx(1.0).epsilon(1e-6));
        // R = 2F / (1 + F) of the sheet.
        TestRng rng(9);
        long n_r = 0;
        const int n = 200000;
        for (int i = 0; i < n; ++i) {
            BsdfSample b = bsdf_sample(thin, glm::vec3(1.0f), dir_cos(-0.3), rng.next(), glm::vec2(0.5f));
            if (b.wi.z < 0.0f)
                ++n_r;
            else
                CHECK(b.wi == -dir_cos(-0.3));
        }
        double f = ref_fresnel_dielectric(0.3, 1.5), r = 2 * f / (1 + f);
        CHECK(std::abs(double(n_r) / n - r) < 5 * std::sqrt(r * (1 - r) / n));
    }
    SUBCASE("roughdielectric: R + T <= 1, > 0.9 at alpha 0.1; principled metal <= 1") {
        for (uint32_t dist : {MF_BECKMANN, MF_GGX}) {
            for (float a : {0.1f, 0.5f}) {
                for (double c : {0.9, 0.5, -0.8}) {
                    FurnaceStats st =
                        furnace(mat_roughdielectric(dist, a, a, 1.5f), dir_cos(c), 200000, 31, undo_radiance_scaling);
                    INFO(std::string(dist_name(dist))
                         << " alpha " << a << " cos " << c << ": " << st.mean << " +- " << st.sd);
                    CHECK(st.mean <= 1.0 + 3 * st.sd + 1e-6);
                    if (a <= 0.1f) CHECK(st.mean > 0.9);
                }
            }
        }
        PrincipledParams p;
        p.metallic = 1.0f;
        p.roughness = 0.316f;
        FurnaceStats st = furnace(mat_principled(p, glm::vec3(1.0f)), dir_cos(0.7), 200000, 37);
        CHECK(st.mean <= 1.0 + 3 * st.sd + 1e-6);
        CHECK(st.mean > 0.9);
        PrincipledParams g;
        g.spec_trans = 1.0f;
        g.roughness = 0.316f;
        st = furnace(mat_principled(g, glm::vec3(1.0f)), dir_cos(0.7), 200000, 41, undo_radiance_scaling);
        CHECK(st.mean <= 1.0 + 3 * st.sd + 1e-6);
        CHECK(st.mean > 0.9);
    }
    SUBCASE("albedo-1 roughdiffuse: exactly 1 at alpha 0 (Lambertian), within 2 % of 1 with roughness") {
        for (double c : {1.0, 0.5, 0.01}) {
            FurnaceStats st = furnace(mat_roughdiffuse(glm::vec3(1.0f), 0.0f), dir_cos(c), 20000, 59);
            CHECK(st.mean == doctest::Approx(1.0).epsilon(1e-5));
        }
        for (float a : {0.2f, 0.6f, 1.5f}) {
            for (double c : {1.0, 0.5, 0.1}) {
                FurnaceStats st = furnace(mat_roughdiffuse(glm::vec3(1.0f), a), dir_cos(c), 200000, 61);
                INFO("alpha " << a << " cos " << c << ": " << st.mean << " +- " << st.sd);
                // Oren-Nayar's full model (single scattering fit plus interreflection) is not
                // energy conserving: measured 1.0016 (alpha 0.2, cos 0.5), 1.0173 (alpha 0.2,
                // cos 0.1), 1.0071 (alpha 0.6, cos 0.1); Mitsuba's is the same formula. It is
                // darkest at normal incidence on the roughest surface: 0.766 (alpha 1.5, cos 1).
                CHECK(st.mean <= 1.02 + 3 * st.sd);
                CHECK(st.mean > 0.75);
            }
        }
    }
    SUBCASE("plastic with a black base reflects F of its coat") {
        for (double c : {1.0, 0.5, 0.1}) {
            FurnaceStats st = furnace(mat_plastic(glm::vec3(0.0f), 1.5f, false), dir_cos(c), 200000, 43);
            INFO("cos " << c);
            CHECK(st.mean == doctest::Approx(ref_fresnel_dielectric(c, 1.5)).epsilon(0.01));
        }
    }
}

TEST_CASE("bsdf: roughplastic tables against smooth limits and the roughdielectric they describe") {
    // Near-smooth coat: T(mu) -> 1 - F(mu), internal reflectance -> the diffuse Fresnel fit.
    GpuMaterial smooth = mat_roughplastic(MF_GGX, 0.001f, glm::vec3(0.5f), 1.5f, false);
    CHECK(roughplastic_prepared(smooth));
    for (double mu = 0.1; mu <= 1.0; mu += 0.05) {
        INFO("mu " << mu);
        CHECK(roughplastic_transmittance(smooth, float(mu)) ==
              doctest::Approx(1.0 - ref_fresnel_dielectric(mu, 1.5)).epsilon(0.01));
    }
    CHECK(roughplastic_internal_reflectance(smooth) ==
          doctest::Approx(fresnel_diffuse_reflectance(1.0f / 1.5f)).epsilon(0.02));
    // Rough coat: T(mu) is the roughdielectric's transmitted energy (eta^2 undone).
    for (uint32_t dist : {MF_BECKMANN, MF_GGX}) {
        GpuMaterial rp = mat_roughplastic(dist, 0.4f, glm::vec3(0.0f), 1.5f, false);
        GpuMaterial rd = mat_roughdielectric(dist, 0.4f, 0.4f, 1.5f);
        for (double mu : {0.95, 0.6, 0.3, 0.12}) {
            glm::vec3 wo = dir_cos(mu, 0.0);
            TestRng rng(51);
            const int n = 200000;
            double t = 0, r = 0;
            for (int i = 0; i < n; ++i) {
                float ul = rng.next();
                BsdfSample b = bsdf_sample(rd, glm::vec3(1.0f), wo, ul, glm::vec2(rng.next(), rng.next()));
                if (!b.ok) continue;
                if (b.wi.z < 0.0f)
                    t += b.weight.x * double(b.eta) * b.eta;
                else
                    r += b.weight.x;
            }
            INFO(std::string(dist_name(dist)) << " mu " << mu);
            CHECK(roughplastic_transmittance(rp, float(mu)) == doctest::Approx(t / n).epsilon(0.015));
            // A black base leaves the coat: roughplastic reflects what roughdielectric reflects.
            FurnaceStats st = furnace(rp, wo, n, 53);
            CHECK(st.mean == doctest::Approx(r / n).epsilon(0.02));
        }
    }
}

TEST_CASE("bsdf: closed forms of the microfacet sample weights") {
    // roughconductor: weight = F(wo.h) G1(wi, h) specular_reflectance, G1 from the reference.
    for (uint32_t dist : {MF_BECKMANN, MF_GGX}) {
        GpuMaterial m = mat_roughconductor(dist, 0.3f, 0.12f);
        TestRng rng(61);
        for (int i = 0; i < 20000; ++i) {
            glm::vec3 wo = dir_cos(0.05 + 0.95 * rng.next_double(), 2 * kPi * rng.next_double());
            BsdfSample b = bsdf_sample(m, glm::vec3(1.0f), wo, rng.next(), glm::vec2(rng.next(), rng.next()));
            if (!b.ok) continue;
            glm::vec3 h = glm::normalize(wo + b.wi);
            double g1 = ref_G1(dist, 0.3, 0.12, b.wi.x, b.wi.y, b.wi.z);
            double c = glm::dot(wo, h);
            glm::vec3 ref(float(ref_fresnel_conductor(c, kGoldEta.x, kGoldK.x) * g1),
                          float(ref_fresnel_conductor(c, kGoldEta.y, kGoldK.y) * g1),
                          float(ref_fresnel_conductor(c, kGoldEta.z, kGoldK.z) * g1));
            CHECK(std::abs(b.weight.x - ref.x) < 2e-4f);
            CHECK(std::abs(b.weight.y - ref.y) < 2e-4f);
            CHECK(std::abs(b.weight.z - ref.z) < 2e-4f);
        }
    }
    // roughdielectric transmission: weight = G1(wi, h) / eta_it^2 (radiance scaling).
    GpuMaterial rd = mat_roughdielectric(MF_GGX, 0.2f, 0.2f, 1.5f);
    TestRng rng(67);
    for (int i = 0; i < 20000; ++i) {
        glm::vec3 wo = dir_cos(rng.next_double() * 2 - 1, 2 * kPi * rng.next_double());
        BsdfSample b = bsdf_sample(rd, glm::vec3(1.0f), wo, rng.next(), glm::vec2(rng.next(), rng.next()));
        if (!b.ok || b.wi.z * wo.z > 0.0f) continue;
        float eta_path = wo.z > 0.0f ? 1.5f : 1.0f / 1.5f;
        CHECK(b.eta == doctest::Approx(eta_path));
        glm::vec3 h = glm::normalize(wo + b.wi * eta_path);
        if (h.z < 0.0f) h = -h;
        double g1 = ref_G1(MF_GGX, 0.2, 0.2, b.wi.x, b.wi.y, b.wi.z);
        CHECK(b.weight.x == doctest::Approx(g1 / (eta_path * eta_path)).epsilon(2e-3));
    }
}

TEST_CASE("bsdf: at alpha 0.001 (too narrow for the chi-square grid) weights still equal eval / pdf") {
    std::vector<std::pair<std::string, GpuMaterial>> narrow;
    for (uint32_t dist : {MF_BECKMANN, MF_GGX}) {
        std::string dn = dist_name(dist);
        narrow.push_back({"roughconductor " + dn, mat_roughconductor(dist, 0.001f, 0.001f)});
        narrow.push_back({"roughconductor aniso " + dn, mat_roughconductor(dist, 0.001f, 0.004f)});
        narrow.push_back({"roughdielectric " + dn, mat_roughdielectric(dist, 0.001f, 0.001f, 1.5f)});
        narrow.push_back({"roughplastic " + dn, mat_roughplastic(dist, 0.001f, glm::vec3(0.5f), 1.5f, false)});
    }
    PrincipledParams p;
    p.roughness = 0.0316f;
    p.spec_trans = 0.5f;
    p.clearcoat = 1.0f;
    p.clearcoat_gloss = 1.0f;
    narrow.push_back({"principled", mat_principled(p, glm::vec3(0.7f))});
    for (const auto& entry : narrow) {
        const std::string& name = entry.first;
        const GpuMaterial& m = entry.second;
        for (double c : {1.0, 0.5, 0.1, 0.01, -0.5}) {
            TestRng rng(91);
            long checked = 0, bad = 0;
            for (int i = 0; i < 20000; ++i) {
                glm::vec3 wo = dir_cos(c, 2 * kPi * rng.next_double());
                float ul = rng.next();
                BsdfSample b = bsdf_sample(m, albedo_of(m), wo, ul, glm::vec2(rng.next(), rng.next()));
                if (!b.ok || b.lobe == LOBE_S) continue;
                ++checked;
                glm::vec3 e = bsdf_eval(m, albedo_of(m), wo, b.wi);
                float pdf = bsdf_pdf(m, albedo_of(m), wo, b.wi);
                glm::vec3 r = e / pdf;
                float tol = 1e-3f * std::max({r.x, r.y, r.z}) + 1e-7f;
                if (!(pdf > 0.0f) || !finite_nonneg(b.weight) || std::abs(b.weight.x - r.x) > tol ||
                    std::abs(b.weight.y - r.y) > tol || std::abs(b.weight.z - r.z) > tol ||
                    std::abs(b.pdf - pdf) > 1e-3f * pdf)
                    ++bad;
            }
            INFO(name << " cos " << c);
            CHECK(bad == 0);
            if (c > 0.0 || name.rfind("roughdielectric", 0) == 0 || name == "principled") CHECK(checked > 1000);
        }
    }
}

TEST_CASE("bsdf: hard cases stay finite and non-negative (1e6 samples each)") {
    struct Hard {
        std::string name;
        GpuMaterial m;
    };
    std::vector<Hard> hard;
    hard.push_back({"diffuse", mat_diffuse(glm::vec3(0.7f))});
    hard.push_back({"conductor", mat_conductor(kGoldEta, kGoldK)});
    for (uint32_t dist : {MF_BECKMANN, MF_GGX}) {
        std::string dn = dist_name(dist);
        hard.push_back({"roughconductor alpha 0.001 " + dn, mat_roughconductor(dist, 0.001f, 0.001f)});
        hard.push_back({"roughconductor alpha 1e-6 (clamped) " + dn, mat_roughconductor(dist, 1e-6f, 1e-6f)});
        hard.push_back({"roughconductor alpha 1 " + dn, mat_roughconductor(dist, 1.0f, 1.0f)});
        hard.push_back({"roughconductor alpha 0.001 x 1 " + dn, mat_roughconductor(dist, 0.001f, 1.0f)});
        for (float eta : {1.0001f, 2.5f})
            for (float a : {0.001f, 1.0f})
                hard.push_back({"roughdielectric " + dn + " eta " + std::to_string(eta) + " alpha " + std::to_string(a),
                                mat_roughdielectric(dist, a, a, eta)});
        hard.push_back(
            {"roughplastic alpha 0.001 eta 2.5 " + dn, mat_roughplastic(dist, 0.001f, glm::vec3(1.0f), 2.5f, true)});
        hard.push_back(
            {"roughplastic alpha 1 eta 1.0001 " + dn, mat_roughplastic(dist, 1.0f, glm::vec3(0.9f), 1.0001f, false)});
    }
    for (float eta : {1.0001f, 2.5f}) {
        hard.push_back({"dielectric eta " + std::to_string(eta), mat_dielectric(MAT_DIELECTRIC, eta)});
        hard.push_back({"thindielectric eta " + std::to_string(eta), mat_dielectric(MAT_THINDIELECTRIC, eta)});
        hard.push_back({"plastic eta " + std::to_string(eta), mat_plastic(glm::vec3(1.0f), eta, true)});
    }
    {
        PrincipledParams p;
        p.roughness = 0.0f;
        p.spec_trans = 1.0f;
        p.eta = 2.5f;
        p.clearcoat = 1.0f;
        p.clearcoat_gloss = 1.0f;
        hard.push_back({"principled roughness 0 spec_trans 1 eta 2.5 clearcoat", mat_principled(p, glm::vec3(1.0f))});
        PrincipledParams q;
        q.roughness = 1.0f;
        q.metallic = 0.5f;
        q.sheen = 1.0f;
        q.spec_tint = 1.0f;
        q.anisotropic = 1.0f;
        q.spec_trans = 0.5f;
        q.eta = 1.0001f;
        hard.push_back({"principled roughness 1 eta 1.0001 everything", mat_principled(q, glm::vec3(1.0f))});
    }

    std::vector<std::string> failures(hard.size());
    std::vector<long> lobes_seen(hard.size());
    std::atomic<size_t> next{0};
    auto work = [&]() {
        for (size_t k = next++; k < hard.size(); k = next++) {
            const GpuMaterial& m = hard[k].m;
            glm::vec3 albedo = albedo_of(m);
            TestRng rng(1000 + k);
            long bad = 0;
            std::string first;
            for (int i = 0; i < 1000000; ++i) {
                // wo: a quarter each grazing (|z| ~ 1e-4), uniform, near-normal, random side.
                double z;
                int mode = i & 3;
                if (mode == 0)
                    z = (1e-4 * (0.5 + 1.5 * rng.next_double()));
                else if (mode == 1)
                    z = 2 * rng.next_double() - 1;
                else if (mode == 2)
                    z = 1 - 1e-6 * rng.next_double();
                else
                    z = 1e-3 * rng.next_double();
                if (rng.next() < 0.5f) z = -z;
                glm::vec3 wo = dir_cos(z, 2 * kPi * rng.next_double());
                float ul = rng.next();
                BsdfSample b = bsdf_sample(m, albedo, wo, ul, glm::vec2(rng.next(), rng.next()));
                bool ok = true;
                if (b.ok) {
                    lobes_seen[k] |= 1L << b.lobe;
                    ok = finite_nonneg(b.weight) && std::isfinite(b.pdf) && b.pdf >= 0.0f &&
                         std::abs(glm::length(b.wi) - 1.0f) < 1e-3f && std::isfinite(b.eta) && b.eta > 0.0f &&
                         (b.lobe == LOBE_S ? b.pdf == 0.0f : b.pdf > 0.0f) && b.lobe != LOBE_NONE;
                }
                glm::vec3 e(0.0f);
                float p = 0.0f;
                if (i % 4 == 0) {  // eval and pdf toward a random direction
                    glm::vec3 wi = square_to_uniform_sphere(glm::vec2(rng.next(), rng.next()));
                    e = bsdf_eval(m, albedo, wo, wi);
                    p = bsdf_pdf(m, albedo, wo, wi);
                    ok = ok && finite_nonneg(e) && std::isfinite(p) && p >= 0.0f;
                }
                if (!ok && bad++ == 0)
                    first = "wo (" + std::to_string(wo.x) + ", " + std::to_string(wo.y) + ", " + std::to_string(wo.z) +
                            ") weight " + std::to_string(b.weight.x) + " pdf " + std::to_string(b.pdf) + " eval " +
                            std::to_string(e.x) + " pdf(wi) " + std::to_string(p);
            }
            if (bad) failures[k] = std::to_string(bad) + " bad values, first: " + first;
        }
    };
    std::vector<std::thread> pool;
    for (unsigned t = 0; t < std::max(1u, std::thread::hardware_concurrency()); ++t) pool.emplace_back(work);
    for (auto& t : pool) t.join();
    for (size_t k = 0; k < hard.size(); ++k) {
        INFO(hard[k].name << ": " << failures[k]);
        CHECK(failures[k].empty());
        uint32_t nee = bsdf_nee_lobe(hard[k].m);
        // Sampled lobes: only S for delta-only materials, never S for delta-free ones.
        if (bsdf_is_delta_only(hard[k].m)) CHECK(lobes_seen[k] == (1L << LOBE_S));
        if (nee == LOBE_G) CHECK(lobes_seen[k] == (1L << LOBE_G));
    }
}

TEST_CASE("bsdf: total internal reflection from inside a dielectric always reflects with weight 1") {
    for (auto [eta, c] : {std::pair{1.0001f, -0.01}, {2.5f, -0.5}, {2.5f, -0.9}}) {
        GpuMaterial m = mat_dielectric(MAT_DIELECTRIC, eta);
        TestRng rng(71);
        for (int i = 0; i < 10000; ++i) {
            glm::vec3 wo = dir_cos(c, 2 * kPi * rng.next_double());
            BsdfSample b = bsdf_sample(m, glm::vec3(1.0f), wo, rng.next(), glm::vec2(0.5f));
            REQUIRE(b.ok);
            CHECK(b.wi.z < 0.0f);
            CHECK(b.weight.x == 1.0f);
            CHECK(b.eta == 1.0f);
            CHECK(b.lobe == LOBE_S);
        }
    }
}

TEST_CASE("bsdf: one-sided and twosided materials and the docs/descriptor.md §2 NEE lobes") {
    SUBCASE("one-sided materials answer nothing from the back; twosided mirrors") {
        glm::vec3 back = dir_cos(-0.6), wi_back = dir_cos(-0.4, 2.0);
        for (uint32_t t : {MAT_DIFFUSE, MAT_PLASTIC, MAT_ROUGHPLASTIC, MAT_CONDUCTOR, MAT_ROUGHCONDUCTOR}) {
            GpuMaterial m = base_material(t);
            INFO("type " << t);
            CHECK_FALSE(bsdf_sample(m, albedo_of(m), back, 0.5f, glm::vec2(0.3f, 0.6f)).ok);
            CHECK(bsdf_eval(m, albedo_of(m), back, wi_back) == glm::vec3(0.0f));
            m.header.y = 1u;
            BsdfSample b = bsdf_sample(m, albedo_of(m), back, 0.9f, glm::vec2(0.3f, 0.6f));
            CHECK(b.ok);
            CHECK(b.wi.z < 0.0f);
            auto flip = [](glm::vec3 v) { return glm::vec3(v.x, v.y, -v.z); };
            CHECK(bsdf_eval(m, albedo_of(m), back, wi_back) == bsdf_eval(m, albedo_of(m), flip(back), flip(wi_back)));
            CHECK(bsdf_pdf(m, albedo_of(m), back, wi_back) == bsdf_pdf(m, albedo_of(m), flip(back), flip(wi_back)));
        }
    }
    SUBCASE("NEE lobe and delta-only per material") {
        struct Row {
            uint32_t type;
            uint32_t lobe;
            bool delta;
        };
        for (Row r : {Row{MAT_DIFFUSE, LOBE_D, false}, Row{MAT_PLASTIC, LOBE_D, false},
                      Row{MAT_ROUGHPLASTIC, LOBE_D, false}, Row{MAT_CONDUCTOR, LOBE_NONE, true},
                      Row{MAT_ROUGHCONDUCTOR, LOBE_G, false}, Row{MAT_DIELECTRIC, LOBE_NONE, true},
                      Row{MAT_ROUGHDIELECTRIC, LOBE_G, false}, Row{MAT_THINDIELECTRIC, LOBE_NONE, true},
                      Row{MAT_PRINCIPLED, LOBE_D, false}, Row{MAT_ROUGHDIFFUSE, LOBE_G, false}}) {
            GpuMaterial m = base_material(r.type);
            INFO("type " << r.type);
            CHECK(bsdf_nee_lobe(m) == r.lobe);
            CHECK(bsdf_is_delta_only(m) == r.delta);
            m.header.y = 1u;  // twosided is transparent to the flags
            CHECK(bsdf_nee_lobe(m) == r.lobe);
        }
        // Principled: D while it has a diffuse component, G without one.
        PrincipledParams p;
        p.metallic = 1.0f;
        CHECK(bsdf_nee_lobe(mat_principled(p, glm::vec3(0.5f))) == LOBE_G);
        p.metallic = 0.0f;
        p.spec_trans = 1.0f;
        CHECK(bsdf_nee_lobe(mat_principled(p, glm::vec3(0.5f))) == LOBE_G);
        p.spec_trans = 0.5f;
        CHECK(bsdf_nee_lobe(mat_principled(p, glm::vec3(0.5f))) == LOBE_D);
        CHECK_FALSE(bsdf_is_delta_only(mat_principled(p, glm::vec3(0.5f))));
    }
    SUBCASE("sampled lobes follow Delta > Diffuse > Glossy") {
        // Smooth plastic: S (coat) or D (base); roughplastic: G or D; both seen.
        for (auto [m, want_a, want_b] :
             {std::tuple{mat_plastic(glm::vec3(0.5f), 1.5f, false), LOBE_S, LOBE_D},
              std::tuple{mat_roughplastic(MF_GGX, 0.2f, glm::vec3(0.5f), 1.5f, false), LOBE_G, LOBE_D},
              std::tuple{mat_principled(PrincipledParams{}, glm::vec3(0.5f)), LOBE_G, LOBE_D}}) {
            TestRng rng(81);
            long seen = 0;
            for (int i = 0; i < 20000; ++i) {
                BsdfSample b =
                    bsdf_sample(m, albedo_of(m), dir_cos(0.3), rng.next(), glm::vec2(rng.next(), rng.next()));
                if (b.ok) seen |= 1L << b.lobe;
            }
            CHECK(seen == ((1L << want_a) | (1L << want_b)));
        }
    }
}

namespace {
// Oren and Nayar (1994), eq. 30 and the interreflection term, written from the
// angles (theta, phi) in double: the reference roughdiffuse_eval_pdf must match.
double oren_nayar_ref(double rho, double alpha, double theta_o, double phi_o, double theta_i, double phi_i) {
    const double s2 = alpha * alpha / 2.0;  // sigma = alpha / sqrt(2)
    const double a = std::max(theta_o, theta_i), b = std::min(theta_o, theta_i);
    const double cphi = std::cos(phi_o - phi_i);
    const double c1 = 1.0 - 0.5 * s2 / (s2 + 0.33);
    const double c2 = cphi > 0.0 ? 0.45 * s2 / (s2 + 0.09) * std::sin(a)
                                 : 0.45 * s2 / (s2 + 0.09) * (std::sin(a) - std::pow(2.0 * b / M_PI, 3.0));
    const double c3 = 0.125 * s2 / (s2 + 0.09) * std::pow(4.0 * a * b / (M_PI * M_PI), 2.0);
    const double l1 = c1 + cphi * c2 * std::tan(b) + (1.0 - std::abs(cphi)) * c3 * std::tan((a + b) / 2.0);
    const double l2 = 0.17 * s2 / (s2 + 0.13) * (1.0 - cphi * std::pow(2.0 * b / M_PI, 2.0));
    // f |cos theta_i|, clamped at 0 as vkmech does (negative far from the normal at alpha > ~1).
    return std::max(0.0, rho * l1 + rho * rho * l2) / M_PI * std::cos(theta_i);
}
}  // namespace

TEST_CASE("bsdf: roughdiffuse evaluates Oren-Nayar's formula and scatters back more than forward") {
    const double rho = 0.6;
    for (double alpha : {0.0, 0.3, 0.8, 1.5})
        for (double to : {0.1, 0.6, 1.2})
            for (double ti : {0.05, 0.7, 1.4})
                for (double dphi : {0.0, 1.0, 2.0, M_PI}) {
                    const double po = 0.3, pi = po + dphi;
                    glm::vec3 wo(std::sin(to) * std::cos(po), std::sin(to) * std::sin(po), std::cos(to));
                    glm::vec3 wi(std::sin(ti) * std::cos(pi), std::sin(ti) * std::sin(pi), std::cos(ti));
                    GpuMaterial m = mat_roughdiffuse(glm::vec3(float(rho)), float(alpha));
                    float pdf = 0.0f;
                    glm::vec3 f = bsdf_eval_pdf(m, albedo_of(m), wo, wi, pdf);
                    const double ref = oren_nayar_ref(rho, alpha, to, po, ti, pi);
                    INFO("alpha " << alpha << " theta_o " << to << " theta_i " << ti << " dphi " << dphi);
                    CHECK(f.x == doctest::Approx(ref).epsilon(2e-4));
                    CHECK(pdf == doctest::Approx(std::cos(ti) / M_PI).epsilon(1e-5));
                }
    // Rough surfaces look brighter towards the light: backscattering (the light
    // behind the viewer) beats forward scattering, and grows with roughness.
    const glm::vec3 wo = dir_cos(0.5, 0.0), back = dir_cos(0.5, 0.0), forward = dir_cos(0.5, M_PI);
    auto f_of = [&](float alpha, glm::vec3 wi) {
        GpuMaterial m = mat_roughdiffuse(glm::vec3(0.6f), alpha);
        return bsdf_eval(m, albedo_of(m), wo, wi).x;
    };
    CHECK(f_of(0.8f, back) > 1.2f * f_of(0.8f, forward));
    CHECK(f_of(0.8f, back) > f_of(0.2f, back));
    CHECK(f_of(0.0f, back) == doctest::Approx(f_of(0.0f, forward)));
}
