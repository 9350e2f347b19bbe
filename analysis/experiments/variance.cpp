// The variance baseline (paper §4.5, docs/descriptor.md §5): split-half reliability of the
// intrinsic variance field per SPP level and per bucket, the convergence
// exponent alpha_hat and its reliability, and the low-vs-high budget Spearman.
// With --taxonomy (docs/lpe.md) the per-bucket columns are the taxonomy's classes, and the
// caustic-dominated scene is the one whose [rare] classes carry the most energy.
#include "experiments/study_context.hpp"
#include "stats/rank.hpp"
#include "stats/regression.hpp"
#include "stats/split_half.hpp"
#include "stats/summary.hpp"

#include <cmath>
#include <optional>

namespace vkmech {

using report::Cell;
using report::Table;

namespace {

constexpr double kBackgroundLum = 1e-4;  // docs/descriptor.md §5: background dropped at mean luminance <= 1e-4
constexpr size_t kMinBucketPixels = 50;  // docs/descriptor.md §5: buckets with < 50 pixels show "---"

// Per-seed mean luminance of one level: m[s][p].
using SeedMeans = std::vector<std::vector<double>>;

constexpr size_t kMinPairs = 3;  // a Spearman over fewer foreground pixels is NaN

// Per-pixel OLS of log10 Var(per-seed mean) on log10 spp (paper App. A: alpha_hat = -slope, 1 for a
// 1/N convergence); NaN where any level is <= 0 or non-finite.
void fit_alpha(const std::vector<std::vector<double>>& var_by_level, const std::vector<uint32_t>& spp,
               std::vector<double>& alpha, std::vector<double>& r2) {
    size_t P = var_by_level.front().size();
    alpha.assign(P, NAN);
    r2.assign(P, NAN);
    std::vector<double> x, y(spp.size());
    for (uint32_t s : spp) x.push_back(std::log10(static_cast<double>(s)));
    for (size_t p = 0; p < P; ++p) {
        bool ok = true;
        for (size_t l = 0; l < spp.size(); ++l) {
            // The estimate's variance at N spp is sigma^2_intrinsic / N: ~N^-1 for plain Monte Carlo.
            double v = var_by_level[l][p] / spp[l];
            if (!(v > 0.0) || !std::isfinite(v)) {
                ok = false;
                break;
            }
            y[l] = std::log10(v);
        }
        if (!ok) continue;
        auto fit = stats::ols(x, y);
        alpha[p] = -fit.slope;
        r2[p] = fit.r2;
    }
}

// ---- compute: per scene the split-half rhos, the per-bucket rhos and alpha_hat ----

// The per-bucket tables' buckets (a taxonomy's tables show every class instead) and their short headers.
const std::vector<uint32_t> kBucketColumns = {gpu::BUCKET_DIRECT, gpu::BUCKET_DIFFUSE_INDIRECT,
                                              gpu::BUCKET_DELTA_MEDIATED, gpu::BUCKET_SPECULAR_DIRECT,
                                              gpu::BUCKET_GLOSSY};
const char* const kBucketHeaders[] = {"dir.", "diff.", "d-m", "spec.", "gloss."};

struct VarianceScene {
    std::string name;
    double rare_share = 0.0;  // the reference's energy share of delta_mediated (or of a taxonomy's [rare] classes)
    std::vector<double> level_rho;                            // per level: split-half rho, mean over partitions
    double max_std = 0.0;                                     // the largest partition std over the levels
    std::vector<std::optional<double>> bucket_hi, bucket_lo;  // per class column; none: too few pixels
    size_t alpha_pixels = 0;
    double median_alpha = 0, median_r2 = 0, alpha_rho = 0, cross_rho = 0;
};

struct VarianceResult {
    size_t partitions = 0;
    std::vector<StudyClass> classes;  // the per-class tables' columns
    std::vector<VarianceScene> scenes;
};

// One scene's per-seed means per level and its foreground masks (mean over seeds above the background).
struct SceneSeeds {
    std::vector<SeedMeans> m;              // level -> seed -> pixel
    std::vector<std::vector<uint8_t>> fg;  // level -> pixel
    std::vector<uint8_t> fg_all;           // foreground at every level
    size_t P = 0;
};

SceneSeeds load_seeds(StudyContext& ctx, const SceneVariant& scene) {
    const StudyConfig& cfg = ctx.cfg;
    const size_t L = cfg.variance_spp.size();
    const int S = cfg.variance_seeds;
    SceneSeeds sd;
    sd.m.resize(L);
    for (size_t l = 0; l < L; ++l)
        for (int s = 0; s < S; ++s)
            sd.m[l].push_back(
                lum_mean_field(ctx.frames.get({scene, cfg.variance_spp[l], seeds::variance(l, s), Estimator::Nee})));
    sd.P = sd.m[0][0].size();
    sd.fg.assign(L, std::vector<uint8_t>(sd.P, 0));
    sd.fg_all.assign(sd.P, 1);
    for (size_t l = 0; l < L; ++l)
        for (size_t p = 0; p < sd.P; ++p) {
            double mean = 0;
            for (int s = 0; s < S; ++s) mean += sd.m[l][s][p];
            sd.fg[l][p] = (mean / S) > kBackgroundLum;
            sd.fg_all[p] &= sd.fg[l][p];
        }
    return sd;
}

// Split-half rho of level l over the pixels of `mask`, one per partition.
std::vector<double> split_half_rhos(const SceneSeeds& sd, size_t l, uint32_t spp,
                                    const std::vector<stats::Partition>& partitions, const std::vector<uint8_t>& mask) {
    std::vector<double> rhos;
    for (const auto& part : partitions)
        rhos.push_back(stats::masked_spearman(intrinsic_variance(sd.m[l], part.a, spp),
                                              intrinsic_variance(sd.m[l], part.b, spp), mask, kMinPairs));
    return rhos;
}

// Per class column at level l: the split-half rho over the foreground pixels of the reference's class.
std::vector<std::optional<double>> bucket_rhos(const SceneSeeds& sd, size_t l, uint32_t spp,
                                               const std::vector<stats::Partition>& partitions,
                                               const std::vector<uint8_t>& dominant,
                                               const std::vector<StudyClass>& classes) {
    std::vector<std::optional<double>> out;
    for (const StudyClass& c : classes) {
        std::vector<uint8_t> mask(sd.P, 0);
        size_t n = 0;
        for (size_t p = 0; p < sd.P; ++p) {
            mask[p] = sd.fg[l][p] && dominant[p] == c.slot;
            n += mask[p];
        }
        if (n < kMinBucketPixels)
            out.push_back(std::nullopt);
        else
            out.push_back(stats::mean(split_half_rhos(sd, l, spp, partitions, mask)));
    }
    return out;
}

// alpha_hat on all seeds, and its split-half reliability.
void alpha_reliability(const SceneSeeds& sd, const StudyConfig& cfg, const std::vector<stats::Partition>& partitions,
                       VarianceScene& r) {
    const size_t L = cfg.variance_spp.size();
    std::vector<int> all(cfg.variance_seeds);
    for (int s = 0; s < cfg.variance_seeds; ++s) all[s] = s;
    std::vector<std::vector<double>> var_all(L);
    for (size_t l = 0; l < L; ++l) var_all[l] = intrinsic_variance(sd.m[l], all, cfg.variance_spp[l]);
    std::vector<double> alpha, r2;
    fit_alpha(var_all, cfg.variance_spp, alpha, r2);
    std::vector<double> a_ok, r_ok;
    for (size_t p = 0; p < sd.P; ++p)
        if (sd.fg_all[p] && std::isfinite(alpha[p])) {
            a_ok.push_back(alpha[p]);
            r_ok.push_back(r2[p]);
        }
    std::vector<double> rhos;
    for (const auto& part : partitions) {
        std::vector<std::vector<double>> va(L), vb(L);
        for (size_t l = 0; l < L; ++l) {
            va[l] = intrinsic_variance(sd.m[l], part.a, cfg.variance_spp[l]);
            vb[l] = intrinsic_variance(sd.m[l], part.b, cfg.variance_spp[l]);
        }
        std::vector<double> aa, ab, r2a, r2b;
        fit_alpha(va, cfg.variance_spp, aa, r2a);
        fit_alpha(vb, cfg.variance_spp, ab, r2b);
        rhos.push_back(stats::masked_spearman(aa, ab, sd.fg_all, kMinPairs));
    }
    std::vector<uint8_t> both(sd.P);
    for (size_t p = 0; p < sd.P; ++p) both[p] = sd.fg[0][p] && sd.fg[L - 1][p];
    r.alpha_pixels = a_ok.size();
    r.median_alpha = stats::median(a_ok);
    r.median_r2 = stats::median(r_ok);
    r.alpha_rho = stats::mean(rhos);
    r.cross_rho = stats::masked_spearman(var_all[0], var_all[L - 1], both, kMinPairs);
}

VarianceScene variance_scene(StudyContext& ctx, const SceneVariant& scene,
                             const std::vector<stats::Partition>& partitions, const std::vector<StudyClass>& classes) {
    const StudyConfig& cfg = ctx.cfg;
    const size_t L = cfg.variance_spp.size();
    VarianceScene r;
    r.name = scene.name;
    Frame ref = ctx.frames.get(
        {scene, cfg.stability_reference_spp(), seeds::stability(cfg.stability_spp.size() - 1), Estimator::Nee});
    Descriptor dref = derive_descriptor(ref);
    const DescriptorSummary sm = summarize(ref, dref);
    if (!ctx.cfg.taxonomy)
        r.rare_share = sm.energy_share[gpu::BUCKET_DELTA_MEDIATED];
    else
        for (const StudyClass& c : classes) r.rare_share += c.rare ? sm.energy_share[c.slot] : 0.0;
    const SceneSeeds sd = load_seeds(ctx, scene);
    for (size_t l = 0; l < L; ++l) {
        const std::vector<double> rhos = split_half_rhos(sd, l, cfg.variance_spp[l], partitions, sd.fg[l]);
        double sdev = std::sqrt(stats::sample_variance(rhos));
        if (std::isfinite(sdev)) r.max_std = std::max(r.max_std, sdev);
        r.level_rho.push_back(stats::mean(rhos));
    }
    r.bucket_hi = bucket_rhos(sd, L - 1, cfg.variance_spp[L - 1], partitions, dref.dominant, classes);
    r.bucket_lo = bucket_rhos(sd, 0, cfg.variance_spp[0], partitions, dref.dominant, classes);
    alpha_reliability(sd, cfg, partitions, r);
    return r;
}

VarianceResult compute_variance(StudyContext& ctx) {
    const auto partitions = stats::random_halves(ctx.cfg.variance_seeds, ctx.cfg.split_half_partitions,
                                                 0);  // docs/descriptor.md §5: base seed 0
    VarianceResult r;
    r.partitions = partitions.size();
    r.classes = study_classes(ctx.cfg, kBucketColumns);
    for (const auto& scene : ctx.cfg.scenes) r.scenes.push_back(variance_scene(ctx, scene, partitions, r.classes));
    return r;
}

// ---- writers ----

Table bucket_table(const StudyConfig& cfg, const std::string& name, const std::string& spp, const VarianceResult& r,
                   bool hi) {
    Table t{name,
            "Split-half sigma^2 self-consistency per " + std::string(cfg.taxonomy ? "class" : "bucket") +
                " at SPP=" + spp + " (tab:sigma-perbucket)",
            {"scene"},
            {},
            ""};
    for (size_t i = 0; i < r.classes.size(); ++i)
        t.columns.push_back(cfg.taxonomy ? r.classes[i].name : kBucketHeaders[i]);
    t.note = cfg.taxonomy ? "Classes of the taxonomy " + cfg.taxonomy->file +
                                " from the reference render's dominant label; \"---\": fewer than 50 pixels."
                          : "Buckets from the reference render's dominant label; \"---\": fewer than 50 pixels.";
    for (const VarianceScene& sc : r.scenes) {
        std::vector<Cell> row{Cell::str(sc.name)};
        for (const auto& rho : hi ? sc.bucket_hi : sc.bucket_lo)
            row.push_back(rho ? Cell::num(*rho, "%.2f") : Cell::str("---"));
        t.add(row);
    }
    return t;
}

Table split_half_table(const StudyConfig& cfg, const VarianceResult& r) {
    Table split{"sigma_splithalf",
                "Split-half self-consistency of sigma^2 per SPP level (tab:sigma-splithalf)",
                {"scene"},
                {},
                ""};
    for (uint32_t s : cfg.variance_spp) split.columns.push_back("SPP=" + std::to_string(s));
    split.columns.push_back("max partition std");
    split.note = "Spearman rho between the sigma^2_intrinsic fields of two disjoint " +
                 std::to_string(cfg.variance_seeds / 2) + "-seed halves, mean over " + std::to_string(r.partitions) +
                 " random partitions (base seed 0); background (mean luminance <= 1e-4) dropped. A noiseless field "
                 "scores 1.";
    for (const VarianceScene& sc : r.scenes) {
        std::vector<Cell> row{Cell::str(sc.name)};
        for (double mu : sc.level_rho) row.push_back(Cell::num(mu));
        row.push_back(Cell::num(sc.max_std, "%.3f"));
        split.add(row);
    }
    return split;
}

Table alpha_table(const StudyConfig& cfg, const VarianceResult& r, const std::string& lo, const std::string& hi) {
    Table alpha_t{"alpha_reliability",
                  "Convergence exponent alpha_hat and the cross-budget rank agreement of sigma^2",
                  {"scene", "pixels fitted", "median alpha_hat", "median R^2", "split-half rho(alpha_hat)",
                   "Spearman sigma^2 " + lo + " vs " + hi},
                  {},
                  ""};
    alpha_t.note =
        "alpha_hat(p) = -slope of the OLS of log10 Var_seeds(per-seed mean luminance) on log10 SPP over the " +
        std::to_string(cfg.variance_spp.size()) +
        " levels (all seeds); pixels with a non-positive or non-finite variance at any level excluded. The "
        "split-half column refits alpha_hat on each half of every partition.";
    for (const VarianceScene& sc : r.scenes)
        alpha_t.add({Cell::str(sc.name), Cell::integer(static_cast<long long>(sc.alpha_pixels)),
                     Cell::num(sc.median_alpha), Cell::num(sc.median_r2), Cell::num(sc.alpha_rho),
                     Cell::num(sc.cross_rho)});
    return alpha_t;
}

report::Figure split_half_figure(const StudyConfig& cfg, const VarianceResult& r) {
    report::Figure fig{"sigma_splithalf", "Split-half rho of sigma^2 versus SPP", "", 1, {}};
    report::Panel panel;
    panel.title = "split-half Spearman of sigma^2 (mean over partitions)";
    panel.xlabel = "SPP";
    panel.ylabel = "rho";
    panel.logx = true;
    fig.panel_size = std::make_pair(6.5, 4.0);
    for (const VarianceScene& sc : r.scenes) {
        report::Series series{sc.name, {}, {}, {}, {}, "", "o", "-", 0, 0, {}};
        for (size_t l = 0; l < sc.level_rho.size(); ++l) {
            series.x.push_back(cfg.variance_spp[l]);
            series.y.push_back(sc.level_rho[l]);
        }
        panel.series.push_back(series);
    }
    fig.panels.push_back(panel);
    return fig;
}

// Shape check: split-half lowest on the caustic-dominated scene (largest delta-mediated energy share; under a
// taxonomy, the largest share of the classes it declares [rare], and no check without any).
void check_caustic_lowest(StudyOutput& out, const StudyConfig& cfg, const VarianceResult& r) {
    std::string rare_names;
    for (const StudyClass& c : r.classes)
        if (c.rare) rare_names += (rare_names.empty() ? "" : ", ") + c.name;
    if (cfg.taxonomy && rare_names.empty()) {
        out.text("Variance baseline", "The taxonomy " + cfg.taxonomy->file +
                                          " declares no class [rare], so the paper's check (the split-half rho is "
                                          "lowest on the caustic-dominated scene) has no caustic classes to read.");
        return;
    }
    const std::string what = cfg.taxonomy ? "the [rare] classes' (" + rare_names + ")" : "delta-mediated";
    std::string lowest_scene, caustic_scene;
    double lowest = INFINITY, caustic_share = -1.0;
    for (const VarianceScene& sc : r.scenes) {
        if (sc.rare_share > caustic_share) {
            caustic_share = sc.rare_share;
            caustic_scene = sc.name;
        }
        const double level_mean = stats::mean(sc.level_rho);
        if (level_mean < lowest) {
            lowest = level_mean;
            lowest_scene = sc.name;
        }
    }
    if (r.scenes.size() > 1)
        out.check("the split-half rho of sigma^2 is lowest on the caustic-dominated scene",
                  lowest_scene == caustic_scene,
                  "lowest (mean over levels): " + lowest_scene + " (" + report::format("%.3f", lowest) + "); largest " +
                      what + " energy share: " + caustic_scene + " (" +
                      report::format("%.1f%%", 100.0 * caustic_share) + ")");
}

void write_variance(StudyOutput& out, const StudyConfig& cfg, const VarianceResult& r) {
    const std::string sec = "Variance baseline";
    const std::string lo = std::to_string(cfg.variance_spp.front()), hi = std::to_string(cfg.variance_spp.back());
    check_caustic_lowest(out, cfg, r);
    if (cfg.taxonomy)
        out.text(sec, "Classes: the taxonomy `" + cfg.taxonomy->file +
                          "` (docs/lpe.md); the per-class tables show each of its classes where the built-in study "
                          "shows five buckets.");
    out.table(sec, split_half_table(cfg, r),
              "1 would be a noiseless reference; low values mean the variance field does not even agree with "
              "itself across a seed split. The paper finds it lowest on the caustic-dominated scene.");
    out.table(
        sec, bucket_table(cfg, "sigma_perbucket", hi, r, true),
        "the same statistic restricted to each dominant label (bucket or class) at the highest variance level: where "
        "within an image the variance signal is unreliable.");
    out.table(sec, bucket_table(cfg, "sigma_perbucket_" + lo, lo, r, false),
              "as above at the lowest variance level (the pilot's regime).");
    out.table(sec, alpha_table(cfg, r, lo, hi),
              "alpha_hat near 1 is Monte Carlo's 1/N; a low split-half rho means the per-pixel exponent "
              "ranking is not reproducible; the last column is how well the low-budget variance ranks "
              "pixels like the high-budget one.");
    out.figure(sec, split_half_figure(cfg, r),
               "one line per scene: split-half rho of sigma^2 against the per-seed budget (log axis).");
}

}  // namespace

void run_variance(StudyContext& ctx) { write_variance(ctx.out, ctx.cfg, compute_variance(ctx)); }

}  // namespace vkmech
