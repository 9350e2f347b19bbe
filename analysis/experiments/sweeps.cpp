// Controlled sweeps (paper §5.4 Finding 3, docs/descriptor.md §5 firefly ratio): one rough
// conductor sphere over eight roughnesses, and 1..16 energy-conserving lights
// at alpha 0.03. Per level: the glossy-dominant population of a reference
// render, the firefly ratio (seed-wise max / mean of the glossy contribution)
// and the split-half rho of sigma^2 over those pixels.
#include "experiments/study_context.hpp"
#include "stats/firefly.hpp"
#include "stats/rank.hpp"
#include "stats/split_half.hpp"
#include "stats/summary.hpp"

#include <cmath>

namespace vkmech {

using report::Cell;
using report::Table;

namespace {

constexpr size_t kMinGlossyPixels = 50;  // as docs/descriptor.md §5's per-bucket rule

void run_sweep(StudyContext& ctx, const std::vector<SceneVariant>& variants, const std::vector<double>& xs,
               const std::vector<std::string>& level_names, const std::string& name, const std::string& section,
               const std::string& xlabel, bool logx, const std::string& title) {
    const StudyConfig& cfg = ctx.cfg;
    const int S = cfg.sweep_seeds;
    const auto partitions = stats::random_halves(S, cfg.split_half_partitions, 0);
    Table t{name,
            title,
            {xlabel, "glossy-dominant px", "glossy energy share", "median firefly", "p90 firefly",
             "split-half rho sigma^2"},
            {},
            ""};
    t.note = "Per level: glossy-dominant pixels of a " + std::to_string(cfg.sweep_ref_spp) +
             "-SPP reference; firefly ratio "
             "per pixel = max / mean over " +
             std::to_string(S) + " seeds (" + std::to_string(cfg.sweep_spp) +
             " SPP each) of the glossy bucket's energy; split-half rho of sigma^2 over the same pixels (" +
             std::to_string(partitions.size()) + " partitions). \"---\": fewer than 50 glossy-dominant pixels.";
    report::Figure fig{name, title, "", 2, {}};
    report::Panel pf, pr;
    pf.title = "firefly ratio over glossy-dominant pixels (median, p50-p90 band)";
    pf.xlabel = xlabel;
    pf.ylabel = "max / mean";
    pf.logx = logx;
    pr.title = "split-half rho of sigma^2 (glossy-dominant pixels)";
    pr.xlabel = xlabel;
    pr.ylabel = "rho";
    pr.logx = logx;
    pr.hlines.push_back({0.0, "", ":", "#888888"});
    report::Series sf{"median", {}, {}, {}, {}, "#D55E00", "o", "-", 0, 0, {}},
        sr{"", {}, {}, {}, {}, "#0072B2", "o", "-", 0, 0, {}};

    for (size_t v = 0; v < variants.size(); ++v) {
        Frame ref = ctx.frames.get({variants[v], cfg.sweep_ref_spp, seeds::sweep_reference(), Estimator::Nee});
        Descriptor d = derive_descriptor(ref);
        DescriptorSummary sum = summarize(ref, d);
        std::vector<size_t> glossy;
        for (size_t p = 0; p < d.dominant.size(); ++p)
            if (d.dominant[p] == gpu::BUCKET_GLOSSY) glossy.push_back(p);
        if (glossy.size() < kMinGlossyPixels) {
            t.add({Cell::str(level_names[v]), Cell::integer(static_cast<long long>(glossy.size())),
                   Cell::pct(sum.energy_share[gpu::BUCKET_GLOSSY]), Cell::str("---"), Cell::str("---"),
                   Cell::str("---")});
            continue;
        }
        std::vector<std::vector<double>> g(S), m(S);
        for (int s = 0; s < S; ++s) {
            Frame f = ctx.frames.get({variants[v], cfg.sweep_spp, seeds::sweep(s), Estimator::Nee});
            auto gf = bucket_field(f, gpu::BUCKET_GLOSSY);
            auto mf = lum_mean_field(f);
            for (size_t p : glossy) {
                g[s].push_back(gf[p]);
                m[s].push_back(mf[p]);
            }
        }
        std::vector<double> ratios;
        for (size_t i = 0; i < glossy.size(); ++i) {
            std::vector<double> per_seed(S);
            for (int s = 0; s < S; ++s) per_seed[s] = g[s][i];
            double r = stats::firefly_ratio(per_seed);
            if (std::isfinite(r)) ratios.push_back(r);
        }
        auto half_var = [&](const std::vector<int>& half) {
            std::vector<double> out(glossy.size()), x(half.size());
            for (size_t i = 0; i < glossy.size(); ++i) {
                for (size_t k = 0; k < half.size(); ++k) x[k] = m[half[k]][i];
                out[i] = cfg.sweep_spp * stats::sample_variance(x);
            }
            return out;
        };
        std::vector<double> rhos;
        for (const auto& part : partitions) rhos.push_back(stats::spearman(half_var(part.a), half_var(part.b)));
        double med = stats::median(ratios), p50 = med, p90 = stats::quantile(ratios, 0.9), rho = stats::mean(rhos);
        t.add({Cell::str(level_names[v]), Cell::integer(static_cast<long long>(glossy.size())),
               Cell::pct(sum.energy_share[gpu::BUCKET_GLOSSY]), Cell::num(med, "%.2f"), Cell::num(p90, "%.2f"),
               Cell::num(rho, "%+.3f")});
        sf.x.push_back(xs[v]);
        sf.y.push_back(med);
        sf.lo.push_back(p50);
        sf.hi.push_back(p90);
        sr.x.push_back(xs[v]);
        sr.y.push_back(rho);
    }
    pf.series.push_back(sf);
    pr.series.push_back(sr);
    fig.panels = {pf, pr};
    ctx.out.table(section, t,
                  "narrow lobes should carry heavier per-pixel tails (larger firefly ratios); the split-half "
                  "column shows whether sigma^2 agrees with itself on the glossy pixels at that level.");
    ctx.out.figure(section, fig,
                   "left: firefly ratio against the level (band p50-p90); right: split-half rho of sigma^2 "
                   "(levels with too few glossy pixels are omitted).");
}

}  // namespace

void run_sweep_roughness(StudyContext& ctx) {
    std::vector<double> xs;
    for (const auto& a : ctx.cfg.sweep_alphas) xs.push_back(std::stod(a));
    std::vector<std::string> names = ctx.cfg.sweep_alphas;
    run_sweep(ctx, roughness_variants(ctx.cfg), xs, names, "sweep_roughness", "Roughness sweep", "alpha", true,
              "Roughness sweep: lobe width versus the glossy heavy tail (fig:roughness-sweep)");
}

void run_sweep_lights(StudyContext& ctx) {
    std::vector<double> xs;
    std::vector<std::string> names;
    for (int n : ctx.cfg.sweep_lights) {
        xs.push_back(n);
        names.push_back(std::to_string(n));
    }
    run_sweep(ctx, light_variants(ctx.cfg), xs, names, "sweep_lights", "Light-count sweep", "lights", true,
              "Light-count sweep at alpha 0.03 (energy-conserving lights)");
}

}  // namespace vkmech
