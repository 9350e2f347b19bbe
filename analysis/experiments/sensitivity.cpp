// Where the paper's premise holds (issue 36, docs/results/sensitivity): one-at-a-time
// variations of what makes glass_caustic heavy-tailed (the light's size at
// fixed power, the sphere's IOR and roughness, the estimator) and of what could
// flatten cubes_dof's variance field (thin-lens aperture, film width, light
// size). Per level, the premise's four measures on the foreground pixels:
//  - split-half rho of sigma^2 at the pilot SPP (docs/descriptor.md §5; paper §4.5),
//  - Spearman rho between the pilot's and the reference's per-pixel variance
//    (what an adaptive sampler sees against what it should see),
//  - agreement of the pilot's dominant label with the reference's (paper §4.3),
//  - the label's margin over the 3- and 7-bin quantile-binned variance labels.
// Under --taxonomy (docs/lpe.md) the labels are the taxonomy's classes and the heavy ones those its
// lines declare [heavy]; every other measure does not depend on the labels.
#include "experiments/study_context.hpp"
#include "stats/agreement.hpp"
#include "stats/rank.hpp"
#include "stats/split_half.hpp"
#include "stats/summary.hpp"

#include <cmath>
#include <map>
#include <utility>

namespace vkmech {

using report::Cell;
using report::Table;

namespace {

constexpr double kBackgroundLum = 1e-4;  // docs/descriptor.md §5: background dropped at mean luminance <= 1e-4
constexpr size_t kMinPairs = 3;
constexpr size_t kMinHeavyPixels = 50;  // as docs/descriptor.md §5's per-bucket rule
constexpr int kK = static_cast<int>(kBucketCount);

// The paper's values that the premise rests on (paper §4.5, tab:variance-baseline).
constexpr double kPaperSplitHalfLo = 0.18, kPaperSplitHalfHi = 0.26;  // glass_caustic
constexpr double kPaperCubesSplitHalf = 0.31;                         // cubes_dof, flat over levels
constexpr double kPaperCrossRho = 0.26;                               // rho(sigma^2_64, sigma^2_ref), glass_caustic

struct Point {
    size_t fg_px = 0;
    double heavy_share = 0;  // energy share of the heavy buckets (or [heavy] classes) in the reference
    double split_half = NAN, split_half_sd = NAN;
    double cross_rho = NAN;
    size_t heavy_px = 0;                               // foreground pixels whose reference label is heavy
    double heavy_split_half = NAN, heavy_cross = NAN;  // the same two rhos over those pixels (NaN below 50)
    double agree = NAN, bin3 = NAN, bin7 = NAN;
};

Point measure_level(StudyContext& ctx, const SensitivityLevel& lv, const std::vector<stats::Partition>& partitions,
                    const HeavyClasses& hs) {
    const StudyConfig& cfg = ctx.cfg;
    const uint32_t n0 = cfg.pilot_spp();
    const Frame pilot = ctx.frames.get({lv.variant, n0, seeds::stability(0), lv.estimator});
    const Frame ref = ctx.frames.get(
        {lv.variant, cfg.stability_reference_spp(), seeds::stability(cfg.stability_spp.size() - 1), lv.estimator});
    const Descriptor dp = derive_descriptor(pilot), dr = derive_descriptor(ref);
    Point pt;
    const DescriptorSummary sm = summarize(ref, dr);
    for (uint32_t b = 0; b < kBucketCount; ++b)
        if (hs.contains(b)) pt.heavy_share += sm.energy_share[b];

    std::vector<std::vector<double>> m;
    for (int s = 0; s < cfg.variance_seeds; ++s)
        m.push_back(lum_mean_field(ctx.frames.get({lv.variant, n0, seeds::sensitivity(s), lv.estimator})));
    const std::vector<double> ref_mean = lum_mean_field(ref);
    std::vector<uint8_t> fg(ref_mean.size(), 0);
    for (size_t p = 0; p < fg.size(); ++p) {
        double seed_mean = 0;
        for (const auto& ms : m) seed_mean += ms[p];
        fg[p] = ref_mean[p] > kBackgroundLum && seed_mean / m.size() > kBackgroundLum;
        pt.fg_px += fg[p];
    }
    std::vector<uint8_t> heavy(fg.size(), 0);
    for (size_t p = 0; p < fg.size(); ++p) {
        heavy[p] = fg[p] && dr.dominant[p] != stats::kNoLabel && hs.contains(dr.dominant[p]);
        pt.heavy_px += heavy[p];
    }
    std::vector<double> rhos, heavy_rhos;
    for (const auto& part : partitions) {
        const auto va = intrinsic_variance(m, part.a, n0), vb = intrinsic_variance(m, part.b, n0);
        rhos.push_back(stats::masked_spearman(va, vb, fg, kMinPairs));
        if (pt.heavy_px >= kMinHeavyPixels) heavy_rhos.push_back(stats::masked_spearman(va, vb, heavy, kMinPairs));
    }
    pt.split_half = stats::mean(rhos);
    pt.split_half_sd = std::sqrt(stats::sample_variance(rhos));
    const auto var_p = lum_var_field(pilot), var_r = lum_var_field(ref);
    pt.cross_rho = stats::masked_spearman(var_p, var_r, fg, kMinPairs);
    if (pt.heavy_px >= kMinHeavyPixels) {
        pt.heavy_split_half = stats::mean(heavy_rhos);
        pt.heavy_cross = stats::masked_spearman(var_p, var_r, heavy, kMinPairs);
    }

    pt.agree = stats::agreement(stats::confusion(dp.dominant, dr.dominant, kK));
    pt.bin3 = stats::agreement(stats::confusion(variance_bins(var_p, dp.dominant, dr.dominant, 3),
                                                variance_bins(var_r, dp.dominant, dr.dominant, 3), 3));
    pt.bin7 = stats::agreement(stats::confusion(variance_bins(var_p, dp.dominant, dr.dominant, 7),
                                                variance_bins(var_r, dp.dominant, dr.dominant, 7), 7));
    return pt;
}

// ---- writers ----

void write_table(StudyOutput& out, const StudyConfig& cfg, const std::string& scene,
                 const std::vector<SensitivityAxis>& axes, const std::vector<std::vector<Point>>& points,
                 size_t partitions, const HeavyClasses& hs) {
    Table t{"sensitivity_" + scene,
            "Sensitivity of the premise on " + scene + ": sigma^2 reliability and label stability per level",
            {"axis", "level", "fg px", "heavy share", "split-half rho sigma^2", "(sd)", "rho(sigma^2 pilot, ref)",
             "heavy px", "split-half, heavy px", "rho(pilot, ref), heavy px", "label agreement", "3-bin sigma^2",
             "7-bin sigma^2", "label / 3-bin", "label / 7-bin"},
            {},
            ""};
    const std::string n0 = std::to_string(cfg.pilot_spp()), ref = std::to_string(cfg.stability_reference_spp());
    // The built-in buckets' wording as before; a taxonomy's [heavy] classes by name.
    const std::string heavy_share = cfg.taxonomy
                                        ? "the energy share of " + hs.declared + " in the "
                                        : std::string("glossy + delta-mediated + specular-direct energy of the ");
    const std::string heavy_px =
        cfg.taxonomy ? "is one of those classes" : "is glossy, delta-mediated or specular-direct";
    t.note =
        "One parameter varied at a time; \"as committed\" is the scene of the other studies. Per level: the "
        "foreground pixels (reference and seed mean above 1e-4); heavy share = " +
        heavy_share + ref + "-SPP reference; split-half rho of sigma^2 over " + std::to_string(cfg.variance_seeds) +
        " seeds x " + n0 + " SPP, mean (and sd) over " + std::to_string(partitions) +
        " random halves; rho(sigma^2 pilot, ref): Spearman of the per-pixel sample variance of the " + n0 +
        "-SPP pilot against the reference's; heavy px: foreground pixels whose reference label " + heavy_px +
        ", with the two rhos over them alone (\"---\" below 50 pixels); label agreement: the pilot's dominant "
        "label against the reference's; the binned columns: the same agreement for quantile-binned variance "
        "labels. The paper's glass_caustic has split-half 0.18-0.26 and rho(sigma^2_64, sigma^2_ref) 0.26; its "
        "cubes_dof 0.31.";
    for (size_t a = 0; a < axes.size(); ++a)
        for (size_t l = 0; l < axes[a].levels.size(); ++l) {
            const Point& p = points[a][l];
            t.add({Cell::str(axes[a].name), Cell::str(axes[a].levels[l].label),
                   Cell::integer(static_cast<long long>(p.fg_px)), Cell::pct(p.heavy_share, 1), Cell::num(p.split_half),
                   Cell::num(p.split_half_sd), Cell::num(p.cross_rho),
                   Cell::integer(static_cast<long long>(p.heavy_px)), Cell::num(p.heavy_split_half),
                   Cell::num(p.heavy_cross), Cell::num(p.agree), Cell::num(p.bin3), Cell::num(p.bin7),
                   Cell::num(p.agree / p.bin3, "%.2fx"), Cell::num(p.agree / p.bin7, "%.2fx")});
        }
    out.table("Sensitivity: " + scene, t,
              "the premise is that sigma^2 is an unreliable difficulty signal (low split-half and pilot-reference "
              "rho) while the label stays stable (high agreement, a clear margin over binned sigma^2); read down "
              "an axis to see which parameter moves which measure.");
}

void write_figure(StudyOutput& out, const std::string& scene, const std::vector<SensitivityAxis>& axes,
                  const std::vector<std::vector<Point>>& points, bool glass) {
    report::Figure fig{"sensitivity_" + scene,
                       "Sensitivity of the premise on " + scene,
                       "",
                       static_cast<int>(std::min<size_t>(axes.size(), 4)),
                       {}};
    for (size_t a = 0; a < axes.size(); ++a) {
        report::Panel p;
        p.title = axes[a].name;
        p.xlabel = axes[a].xlabel;
        p.ylabel = "rho / agreement";
        p.logx = axes[a].logx;
        p.ylim = std::make_pair(-0.1, 1.05);
        report::Series sh{"split-half rho sigma^2", {}, {}, {}, {}, "#D55E00", "o", "-", 0, 0, {}},
            cr{"rho(sigma^2 pilot, ref)", {}, {}, {}, {}, "#E69F00", "s", "--", 0, 0, {}},
            ag{"label agreement", {}, {}, {}, {}, "#0072B2", "^", "-", 0, 0, {}},
            b3{"3-bin sigma^2 agreement", {}, {}, {}, {}, "#888888", "v", ":", 0, 0, {}},
            hs{"split-half, heavy px", {}, {}, {}, {}, "#CC79A7", "D", "-.", 0, 0, {}};
        for (size_t l = 0; l < axes[a].levels.size(); ++l) {
            const double x = axes[a].levels[l].x;
            const Point& pt = points[a][l];
            for (auto [s, y] : {std::pair{&sh, pt.split_half}, {&cr, pt.cross_rho}, {&ag, pt.agree}, {&b3, pt.bin3}}) {
                s->x.push_back(x);
                s->y.push_back(y);
            }
            sh.lo.push_back(pt.split_half - pt.split_half_sd);
            sh.hi.push_back(pt.split_half + pt.split_half_sd);
            hs.x.push_back(x);
            hs.y.push_back(pt.heavy_split_half);
        }
        p.series = {sh, cr, ag, b3};
        if (glass) p.series.push_back(hs);
        if (glass) {
            p.hlines.push_back({kPaperSplitHalfLo, "paper split-half 0.18-0.26", "--", "#D55E00"});
            p.hlines.push_back({kPaperSplitHalfHi, "", "--", "#D55E00"});
        } else {
            p.hlines.push_back({kPaperCubesSplitHalf, "paper split-half 0.31", "--", "#D55E00"});
        }
        fig.panels.push_back(p);
    }
    out.figure("Sensitivity: " + scene, fig,
               "each panel varies one parameter (the scene as committed is one of its points); dashed red lines: "
               "the paper's sigma^2 split-half on this scene; the band: +-1 sd over the random halves.");
}

// A plain statement per scene: which levels reach the paper's sigma^2 reliability, and what the label does there.
void write_verdict(StudyOutput& out, const std::string& scene, const std::vector<SensitivityAxis>& axes,
                   const std::vector<std::vector<Point>>& points, bool glass) {
    const double hi = glass ? kPaperSplitHalfHi : kPaperCubesSplitHalf + 0.05;
    std::string md = "**" + scene + "**: levels whose sigma^2 split-half is at or below " + report::format("%.2f", hi) +
                     (glass ? " (the top of the paper's 0.18-0.26)" : " (the paper's flat 0.31, plus 0.05)") + ": ";
    std::string found;
    double lowest = INFINITY;
    std::string lowest_at;
    for (size_t a = 0; a < axes.size(); ++a)
        for (size_t l = 0; l < axes[a].levels.size(); ++l) {
            const Point& p = points[a][l];
            if (p.split_half < lowest) {
                lowest = p.split_half;
                lowest_at = axes[a].name + " = " + axes[a].levels[l].label;
            }
            if (!(p.split_half <= hi)) continue;
            found += (found.empty() ? "" : "; ") + axes[a].name + " = " + axes[a].levels[l].label + " (split-half " +
                     report::format("%.3f", p.split_half) + ", rho(pilot, ref) " + report::format("%.3f", p.cross_rho) +
                     ", label agreement " + report::format("%.3f", p.agree) + ", label / 3-bin " +
                     report::format("%.2fx", p.agree / p.bin3) + ")";
        }
    md += found.empty() ? "none. The lowest is " + report::format("%.3f", lowest) + " at " + lowest_at + "."
                        : found + ".";
    if (glass)
        md += " (The paper's rho(sigma^2_64, sigma^2_ref) on glass_caustic is " +
              report::format("%.2f", kPaperCrossRho) + ".)";
    out.text("Sensitivity: " + scene, md);
}

}  // namespace

void run_sensitivity(StudyContext& ctx) {
    const std::vector<SensitivityAxis> all = sensitivity_axes(ctx.cfg);
    if (all.empty()) {
        ctx.out.text("Sensitivity",
                     "No scene of this study has sensitivity axes: they are defined for glass_caustic and cubes_dof "
                     "(pass them with --scenes).");
        return;
    }
    const auto partitions = stats::random_halves(ctx.cfg.variance_seeds, ctx.cfg.split_half_partitions, 0);
    const HeavyClasses hs = heavy_classes(ctx.cfg);
    // Axes come grouped by scene (sensitivity_axes walks cfg.scenes).
    for (size_t first = 0; first < all.size();) {
        size_t last = first;
        while (last < all.size() && all[last].scene == all[first].scene) ++last;
        const std::vector<SensitivityAxis> axes(all.begin() + first, all.begin() + last);
        // The committed scene is a level of every axis: measure each (variant, estimator) once.
        std::map<std::pair<SceneVariant, Estimator>, Point> measured;
        std::vector<std::vector<Point>> points;
        for (const auto& axis : axes) {
            points.emplace_back();
            for (const auto& lv : axis.levels) {
                auto [it, fresh] = measured.try_emplace({lv.variant, lv.estimator});
                if (fresh) it->second = measure_level(ctx, lv, partitions, hs);
                points.back().push_back(it->second);
            }
        }
        const std::string& scene = axes.front().scene;
        const bool glass = scene.find("glass_caustic") != std::string::npos;
        write_table(ctx.out, ctx.cfg, scene, axes, points, partitions.size(), hs);
        write_figure(ctx.out, scene, axes, points, glass);
        write_verdict(ctx.out, scene, axes, points, glass);
        first = last;
    }
}

}  // namespace vkmech
