#include "experiments/study_config.hpp"

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>

namespace vkmech {

namespace {
const std::vector<std::pair<StudyKind, const char*>> kStudyNames = {{StudyKind::Stability, "stability"},
                                                                    {StudyKind::Variance, "variance"},
                                                                    {StudyKind::Cost, "cost"},
                                                                    {StudyKind::Structure, "structure"},
                                                                    {StudyKind::SweepRoughness, "sweep-roughness"},
                                                                    {StudyKind::SweepLights, "sweep-lights"},
                                                                    {StudyKind::Predictor, "predictor"},
                                                                    {StudyKind::Allocation, "allocation"},
                                                                    {StudyKind::Sensitivity, "sensitivity"}};

std::string join(const std::vector<uint32_t>& v) {
    std::string s;
    for (size_t i = 0; i < v.size(); ++i) {
        if (i) s += '/';
        s += std::to_string(v[i]);
    }
    return s;
}

void check_ascending(const std::vector<uint32_t>& v, const char* what) {
    if (v.empty()) throw std::invalid_argument(std::string(what) + ": no levels");
    for (size_t i = 0; i < v.size(); ++i) {
        if (v[i] == 0) throw std::invalid_argument(std::string(what) + ": a level of 0 spp");
        if (i && v[i] <= v[i - 1])
            throw std::invalid_argument(std::string(what) + ": levels must be strictly ascending");
    }
}
}  // namespace

const char* to_string(StudyKind k) {
    for (const auto& [kind, name] : kStudyNames)
        if (kind == k) return name;
    return "?";
}

std::vector<StudyKind> parse_study(const std::string& name) {
    if (name == "all") {
        std::vector<StudyKind> all;
        for (const auto& [kind, n] : kStudyNames)
            if (kind != StudyKind::Sensitivity) all.push_back(kind);
        return all;
    }
    for (const auto& [kind, n] : kStudyNames)
        if (name == n) return {kind};
    std::string valid = "all";
    for (const auto& [kind, n] : kStudyNames) valid += std::string(", ") + n;
    throw std::invalid_argument("unknown study '" + name + "' (valid: " + valid + ")");
}

void StudyConfig::validate(bool needs_cost) const {
    check_ascending(stability_spp, "stability levels");
    if (stability_spp.size() < 2)
        throw std::invalid_argument("stability levels: need at least two (a pilot and the reference)");
    check_ascending(variance_spp, "variance levels");
    if (variance_spp.size() < 2) throw std::invalid_argument("variance levels: need at least two for the exponent fit");
    check_ascending(cost_spp, "cost levels");
    if (needs_cost && cost_spp.back() >= stability_reference_spp())
        throw std::invalid_argument("cost levels must stay below the reference (" +
                                    std::to_string(stability_reference_spp()) + " spp)");
    if (variance_seeds < 4 || variance_seeds % 2)
        throw std::invalid_argument("--seeds must be even and at least 4 (split-half uses two equal halves)");
    if (sweep_seeds < 4 || sweep_seeds % 2) throw std::invalid_argument("sweep seeds must be even and at least 4");
    if (res < 4 || res > 4096) throw std::invalid_argument("--res must be in [4, 4096]");
    if (alloc_pools < 1 || alloc_pools > 100) throw std::invalid_argument("--pools must be in [1, 100]");
}

std::string StudyConfig::describe() const {
    std::ostringstream o;
    o << "preset " << preset << ": film width " << res << " px; stability SPP " << join(stability_spp) << " (reference "
      << stability_reference_spp() << ", pilot " << pilot_spp() << "); variance SPP " << join(variance_spp) << " x "
      << variance_seeds << " seeds; time-to-quality SPP " << join(cost_spp) << " against the reference (tau "
      << cost_tau << "); sweeps " << sweep_seeds << " seeds x " << sweep_spp << " SPP + a " << sweep_ref_spp
      << "-SPP reference per level; allocation at " << alloc_res << " px: pilots " << join(alloc_pilots) << " SPP x "
      << alloc_draws << " draws, extra budget " << alloc_extra << " SPP (sweep " << join(alloc_budget_sweep)
      << "), floors " << join(alloc_floors) << ", reference " << alloc_ref_chunks * alloc_ref_chunk_spp << " SPP, "
      << alloc_pools << (alloc_pools == 1 ? " pool" : " pools") << " of 256 frames";
    return o.str();
}

StudyConfig preset_config(const std::string& name) {
    StudyConfig c;
    c.preset = name;
    if (name == "quick") {
        return c;  // the defaults: tiny images, low spp, the whole pipeline in minutes
    }
    if (name == "reduced") {
        c.res = 96;
        c.stability_spp = {64, 512, 2048};
        c.variance_spp = {8, 32, 128, 512};
        c.cost_spp = {16, 32, 64, 128, 256, 512, 1024};
        c.sweep_spp = 32;
        c.sweep_seeds = 30;  // a firefly ratio (max / mean over seeds) can reach 30, not only 10
        c.sweep_ref_spp = 512;
        c.batch_spp = 64;
        c.alloc_res = 96;
        c.alloc_ref_chunks = 4;
        c.alloc_ref_chunk_spp = 512;
        c.alloc_pools = 5;
        return c;
    }
    if (name == "paper") {
        c.res = 256;
        c.stability_spp = {64, 512, 4096};
        c.variance_spp = {64, 256, 1024, 4096};
        c.cost_spp = {16, 32, 64, 128, 256, 512, 1024, 2048};
        c.sweep_spp = 128;
        c.sweep_seeds = 30;
        c.sweep_ref_spp = 4096;
        c.sweep_lights = {1, 2, 3, 4, 6, 8, 12, 16};
        c.batch_spp = 64;
        c.alloc_res = 256;
        c.alloc_ref_chunks = 8;
        c.alloc_ref_chunk_spp = 512;
        c.alloc_pools = 5;
        return c;
    }
    throw std::invalid_argument("unknown preset '" + name + "' (valid: quick, reduced, paper)");
}

namespace seeds {
uint32_t stability(size_t level) { return 100 + static_cast<uint32_t>(level); }
uint32_t mis_disjoint_reference() { return 150; }
uint32_t nee_disjoint_reference() { return 151; }
uint32_t variance(size_t level, int s) { return 2000 + 100 * static_cast<uint32_t>(level) + static_cast<uint32_t>(s); }
uint32_t cost(size_t level) { return 3000 + static_cast<uint32_t>(level); }
uint32_t sweep(int s) { return 4000 + static_cast<uint32_t>(s); }
uint32_t sweep_reference() { return 4999; }
uint32_t sensitivity(int s) { return 6000 + static_cast<uint32_t>(s); }
}  // namespace seeds

std::vector<SceneVariant> roughness_variants(const StudyConfig& cfg) {
    std::vector<SceneVariant> v;
    for (const auto& a : cfg.sweep_alphas)
        v.push_back({"sweep_roughness alpha=" + a, cfg.sweep_roughness_scene, {{"alpha", a}}});
    return v;
}

std::vector<SceneVariant> light_variants(const StudyConfig& cfg) {
    std::vector<SceneVariant> v;
    for (int n : cfg.sweep_lights)
        v.push_back(
            {"sweep_lights lights=" + std::to_string(n), cfg.sweep_lights_scene, {{"lights", std::to_string(n)}}});
    return v;
}

namespace {

std::string number_text(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

// An RGB radiance scaled by k, as a Mitsuba value list.
std::string scaled_rgb(const std::array<double, 3>& rgb, double k) {
    return number_text(rgb[0] * k) + ", " + number_text(rgb[1] * k) + ", " + number_text(rgb[2] * k);
}

// `name`: the variant's display suffix (its parameters in short).
SensitivityLevel level_of(const SceneVariant& base, std::map<std::string, std::string> params, double x,
                          const std::string& label, const std::string& name) {
    SceneVariant v = base;
    v.params = std::move(params);
    v.name = base.name + " " + name;
    return {v, Estimator::Nee, x, label};
}

// The light's half-width s at the power of the committed light (half-width s0,
// radiance rgb): the radiance scales with (s0 / s)^2.
SensitivityAxis light_size_axis(const SceneVariant& base, double s0, const std::array<double, 3>& rgb,
                                const std::vector<double>& sizes) {
    SensitivityAxis a{base.name, "light size at fixed power", "light half-width (m)", true, {}, 0};
    for (double s : sizes) {
        if (s == s0) {
            a.base = a.levels.size();
            a.levels.push_back({base, Estimator::Nee, s, number_text(s) + " (as committed)"});
            continue;
        }
        const double k = (s0 / s) * (s0 / s);
        a.levels.push_back(level_of(base, {{"light_size", number_text(s)}, {"light_radiance", scaled_rgb(rgb, k)}}, s,
                                    number_text(s), "light_size=" + number_text(s) + " (fixed power)"));
    }
    return a;
}

// One parameter over values; `committed` is the scene's own value.
SensitivityAxis param_axis(const SceneVariant& base, const std::string& name, const std::string& xlabel,
                           const std::string& param, const std::vector<double>& values, double committed, bool logx) {
    SensitivityAxis a{base.name, name, xlabel, logx, {}, 0};
    for (double v : values) {
        if (v == committed) {
            a.base = a.levels.size();
            a.levels.push_back({base, Estimator::Nee, v, number_text(v) + " (as committed)"});
        } else {
            a.levels.push_back(
                level_of(base, {{param, number_text(v)}}, v, number_text(v), param + "=" + number_text(v)));
        }
    }
    return a;
}

void glass_caustic_axes(const SceneVariant& base, std::vector<SensitivityAxis>& out) {
    out.push_back(light_size_axis(base, 0.2, {40, 35, 27}, {0.025, 0.05, 0.1, 0.2, 0.4}));
    out.push_back(param_axis(base, "sphere IOR", "int_ior", "ior", {1.1, 1.33, 1.5, 1.8, 2.4}, 1.5, false));
    SensitivityAxis rough{base.name, "sphere roughness", "GGX alpha (0: smooth dielectric)", false, {}, 0};
    rough.levels.push_back({base, Estimator::Nee, 0.0, "smooth (as committed)"});
    for (double al : {0.01, 0.03, 0.1, 0.3})
        rough.levels.push_back(level_of(base, {{"sphere", "rough_glass"}, {"alpha", number_text(al)}}, al,
                                        number_text(al), "rough glass alpha=" + number_text(al)));
    out.push_back(rough);
    SensitivityAxis est{base.name, "estimator", "0 nee, 1 mis-restricted, 2 mis", false, {}, 0};
    est.levels.push_back({base, Estimator::Nee, 0.0, "nee (as committed)"});
    est.levels.push_back({base, Estimator::MisRestricted, 1.0, "mis-restricted"});
    est.levels.push_back({base, Estimator::Mis, 2.0, "mis"});
    out.push_back(est);
}

void cubes_dof_axes(const StudyConfig& cfg, const SceneVariant& base, std::vector<SensitivityAxis>& out) {
    out.push_back(param_axis(base, "thin-lens aperture", "aperture radius (m)", "aperture",
                             {0.0125, 0.025, 0.05, 0.1, 0.2}, 0.1, true));
    SensitivityAxis film{base.name, "film width (pixel footprint)", "film width (px)", true, {}, 0};
    for (int r : {cfg.res / 2, cfg.res, cfg.res * 2}) {
        SceneVariant v = base;
        if (r != cfg.res) {
            v.res = r;
            v.name = base.name + " res=" + std::to_string(r);
        } else {
            film.base = film.levels.size();
        }
        film.levels.push_back(
            {v, Estimator::Nee, static_cast<double>(r), std::to_string(r) + (r == cfg.res ? " (the study's)" : "")});
    }
    out.push_back(film);
    out.push_back(light_size_axis(base, 1.0, {10, 10, 10}, {0.25, 0.5, 1.0}));
}

}  // namespace

std::vector<SensitivityAxis> sensitivity_axes(const StudyConfig& cfg) {
    std::vector<SensitivityAxis> out;
    for (const auto& sc : cfg.scenes) {
        const std::string stem = std::filesystem::path(sc.path).stem().string();
        if (!sc.params.empty() || sc.res != 0) continue;  // the axes vary the scene as committed
        if (stem == "glass_caustic") glass_caustic_axes(sc, out);
        if (stem == "cubes_dof") cubes_dof_axes(cfg, sc, out);
    }
    return out;
}

std::vector<RenderRequest> plan_renders(const StudyConfig& cfg, StudyKind kind) {
    std::vector<RenderRequest> out;
    auto stability_ref = [&](const SceneVariant& s, Estimator e) {
        out.push_back({s, cfg.stability_reference_spp(), seeds::stability(cfg.stability_spp.size() - 1), e});
    };
    auto pilot = [&](const SceneVariant& s, Estimator e) {
        out.push_back({s, cfg.pilot_spp(), seeds::stability(0), e});
    };
    auto sweep = [&](const std::vector<SceneVariant>& variants) {
        for (const auto& v : variants) {
            out.push_back({v, cfg.sweep_ref_spp, seeds::sweep_reference(), Estimator::Nee});
            for (int s = 0; s < cfg.sweep_seeds; ++s)
                out.push_back({v, cfg.sweep_spp, seeds::sweep(s), Estimator::Nee});
        }
    };
    switch (kind) {
        case StudyKind::Stability:
            for (const auto& s : cfg.scenes) {
                for (size_t i = 0; i < cfg.stability_spp.size(); ++i)
                    out.push_back({s, cfg.stability_spp[i], seeds::stability(i), Estimator::Nee});
                if (cfg.taxonomy) continue;  // a user taxonomy's stability needs the levels only
                // docs/descriptor.md §5 / paper tab:robust-mis: the restricted-MIS estimator at the pilot and the
                // reference.
                pilot(s, Estimator::MisRestricted);
                stability_ref(s, Estimator::MisRestricted);
                // The same comparison on seeds disjoint from the NEE reference, and its NEE noise floor.
                out.push_back(
                    {s, cfg.stability_reference_spp(), seeds::mis_disjoint_reference(), Estimator::MisRestricted});
                out.push_back({s, cfg.stability_reference_spp(), seeds::nee_disjoint_reference(), Estimator::Nee});
                // docs/descriptor.md §2: the literal end-vertex reading at the pilot and the reference, for the
                // comparison of the two readings (same seeds as the default reading's renders).
                out.push_back({s, cfg.pilot_spp(), seeds::stability(0), Estimator::Nee, EndVertex::Literal});
                out.push_back({s, cfg.stability_reference_spp(), seeds::stability(cfg.stability_spp.size() - 1),
                               Estimator::Nee, EndVertex::Literal});
            }
            break;
        case StudyKind::Variance:
            for (const auto& s : cfg.scenes) {
                stability_ref(s, Estimator::Nee);  // labels for the per-bucket split
                for (size_t l = 0; l < cfg.variance_spp.size(); ++l)
                    for (int k = 0; k < cfg.variance_seeds; ++k)
                        out.push_back({s, cfg.variance_spp[l], seeds::variance(l, k), Estimator::Nee});
            }
            break;
        case StudyKind::Cost:
            for (const auto& s : cfg.scenes) {
                stability_ref(s, Estimator::Nee);
                for (size_t l = 0; l < cfg.cost_spp.size(); ++l)
                    out.push_back({s, cfg.cost_spp[l], seeds::cost(l), Estimator::Nee});
            }
            break;
        case StudyKind::Structure:
            for (const auto& s : cfg.scenes) stability_ref(s, Estimator::Nee);
            break;
        case StudyKind::SweepRoughness:
            sweep(roughness_variants(cfg));
            break;
        case StudyKind::SweepLights:
            sweep(light_variants(cfg));
            break;
        case StudyKind::Sensitivity:
            for (const auto& axis : sensitivity_axes(cfg))
                for (const auto& lv : axis.levels) {
                    out.push_back({lv.variant, cfg.pilot_spp(), seeds::stability(0), lv.estimator});
                    out.push_back({lv.variant, cfg.stability_reference_spp(),
                                   seeds::stability(cfg.stability_spp.size() - 1), lv.estimator});
                    for (int s = 0; s < cfg.variance_seeds; ++s)
                        out.push_back({lv.variant, cfg.pilot_spp(), seeds::sensitivity(s), lv.estimator});
                }
            break;
        case StudyKind::Allocation:  // its pool, pilots and reference come from an AllocationSource
                                     // (experiments/allocation.hpp)
            break;
        case StudyKind::Predictor:
            for (const auto& s : cfg.scenes) {
                pilot(s, Estimator::Nee);
                if (cfg.predictor_curve.empty()) stability_ref(s, Estimator::Nee);
            }
            break;
    }
    return out;
}

}  // namespace vkmech
