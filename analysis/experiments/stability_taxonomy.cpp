// `vkmech study stability --taxonomy FILE` (docs/lpe.md, issue 37): the stability study's
// class-agnostic measures for a user taxonomy's classes. Per scene: each class's pixel and energy
// share at the reference, the dominant class's agreement at every level with the reference
// (with a tile-bootstrap interval and Cohen's kappa at the pilot), and the quantile-binned
// variance baseline at 3 and 7 bins. The measures that read the paper's buckets (the tail
// families' struct% and weighted kappa, the end-vertex readings, restricted MIS) have no meaning
// for another taxonomy and are not computed.
#include "experiments/study_context.hpp"
#include "stats/agreement.hpp"
#include "stats/bootstrap.hpp"

#include <algorithm>
#include <cmath>

namespace vkmech {

using report::Cell;
using report::Table;

namespace {

struct TaxonomyScene {
    std::string name;
    std::vector<double> pixel_share, energy_share;  // per class, at the reference
    std::vector<double> level_agree;                // per level below the reference
    double kappa = 0, bin3 = 0, bin7 = 0;
    stats::Interval agree_ci;
};

TaxonomyScene taxonomy_scene(StudyContext& ctx, const SceneVariant& scene, int k) {
    const StudyConfig& cfg = ctx.cfg;
    const size_t nl = cfg.stability_spp.size();
    std::vector<Frame> frames;
    std::vector<std::vector<uint8_t>> dominant;
    for (size_t i = 0; i < nl; ++i) {
        frames.push_back(ctx.frames.get({scene, cfg.stability_spp[i], seeds::stability(i), Estimator::Nee}));
        dominant.push_back(derive_descriptor(frames.back()).dominant);
    }
    TaxonomyScene sc;
    sc.name = scene.name;
    const auto &pil = dominant.front(), &ref = dominant.back();
    for (size_t i = 0; i + 1 < nl; ++i)
        sc.level_agree.push_back(stats::agreement(stats::confusion(dominant[i], ref, k)));
    const stats::Confusion conf = stats::confusion(pil, ref, k);
    sc.kappa = stats::cohen_kappa(conf);
    sc.agree_ci = stats::tile_bootstrap(
        pil, ref, k, frames.back().width, 8, [](const stats::Confusion& c) { return stats::agreement(c); }, 2000, 0);
    const auto var_p = lum_var_field(frames.front()), var_r = lum_var_field(frames.back());
    sc.bin3 =
        stats::agreement(stats::confusion(variance_bins(var_p, pil, ref, 3), variance_bins(var_r, pil, ref, 3), 3));
    sc.bin7 =
        stats::agreement(stats::confusion(variance_bins(var_p, pil, ref, 7), variance_bins(var_r, pil, ref, 7), 7));
    sc.pixel_share = stats::pixel_shares(ref, k);
    const Descriptor d = derive_descriptor(frames.back());
    const DescriptorSummary sm = summarize(frames.back(), d);
    for (int b = 0; b < k; ++b) sc.energy_share.push_back(sm.energy_share[b]);
    return sc;
}

}  // namespace

void run_stability_taxonomy(StudyContext& ctx) {
    const StudyConfig& cfg = ctx.cfg;
    const lpe::TaxonomySource& tax = *cfg.taxonomy;
    std::vector<std::string> names;
    for (const StudyClass& c : study_classes(cfg, {})) names.push_back(c.name);
    const int k = static_cast<int>(names.size());
    std::vector<TaxonomyScene> scenes;
    for (const auto& scene : cfg.scenes) scenes.push_back(taxonomy_scene(ctx, scene, k));
    const std::string pilot = std::to_string(cfg.pilot_spp()), top = std::to_string(cfg.stability_reference_spp());

    Table shares{"taxonomy_shares",
                 "The taxonomy's classes at " + top + " SPP (" + tax.file +
                     "): share of pixels each class dominates / "
                     "share of the image's energy",
                 {"scene"},
                 {},
                 "The classes partition every pixel's energy (docs/lpe.md); `other` takes what no line matches."};
    for (const auto& n : names) shares.columns.push_back(n);
    for (const auto& sc : scenes) {
        std::vector<Cell> r{Cell::str(sc.name)};
        for (int b = 0; b < k; ++b)
            r.push_back(
                Cell::str(Cell::pct(sc.pixel_share[b], 1).text + " / " + Cell::pct(sc.energy_share[b], 1).text));
        shares.add(r);
    }
    ctx.out.table("Taxonomy", shares,
                  "which classes the scene's pixels fall in at the reference: the first figure counts the pixels whose "
                  "dominant class it is, the second the class's share of the image's energy.");

    Table stab{"taxonomy_stability",
               "Cross-SPP stability of the dominant class (" + tax.file + "), against the quantile-binned variance",
               {"scene"},
               {},
               "Agreement with the " + top + "-SPP reference; kappa and the 95% tile-bootstrap interval at the " +
                   pilot +
                   "-SPP pilot; var3 and var7: the same agreement for sigma^2 binned into 3 and 7 quantile "
                   "bins (docs/descriptor.md §5). Margin: the class label's agreement minus the better of "
                   "the two."};
    for (size_t i = 0; i + 1 < cfg.stability_spp.size(); ++i)
        stab.columns.push_back(std::to_string(cfg.stability_spp[i]) + " spp");
    for (const char* c : {"pilot 95% CI", "kappa", "var3", "var7", "margin"}) stab.columns.push_back(c);
    size_t beats = 0;
    for (const auto& sc : scenes) {
        std::vector<Cell> r{Cell::str(sc.name)};
        for (double a : sc.level_agree) r.push_back(Cell::pct(a));
        r.push_back(Cell::str(Cell::pct(sc.agree_ci.lo).text + " - " + Cell::pct(sc.agree_ci.hi).text));
        r.push_back(Cell::num(sc.kappa));
        r.push_back(Cell::pct(sc.bin3));
        r.push_back(Cell::pct(sc.bin7));
        const double margin = sc.level_agree.front() - std::max(sc.bin3, sc.bin7);
        r.push_back(Cell::num(margin, "%+.3f"));
        stab.add(r);
        beats += margin > 0 ? 1 : 0;
    }
    ctx.out.table("Taxonomy", stab,
                  "a class label that stays put as the SPP grows is a stable difficulty signal; the binned variance is "
                  "the incumbent it is measured against.");
    ctx.out.check("the taxonomy's dominant class is more stable than binned sigma^2 on every scene",
                  beats == scenes.size(),
                  std::to_string(beats) + " of " + std::to_string(scenes.size()) + " scenes at the " + pilot +
                      "-SPP pilot (" + tax.file + ")");
}

}  // namespace vkmech
