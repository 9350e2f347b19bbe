// Controlled sweeps (paper §5.4 Finding 3, docs/descriptor.md §5 firefly ratio): one rough
// conductor sphere over eight roughnesses, and 1..16 energy-conserving lights
// at alpha 0.03. Per level: the glossy-dominant population of a reference
// render, the firefly ratio (seed-wise max / mean of the glossy contribution)
// and the split-half rho of sigma^2 over those pixels. Under --taxonomy (docs/lpe.md) the population is
// that of the classes the taxonomy declares [heavy], and the firefly ratio reads their summed energy; a
// taxonomy whose only [heavy] class is the buckets' glossy gives the built-in tables.
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

// What a sweep varies and how its outputs are named.
struct SweepSpec {
    std::vector<SceneVariant> variants;
    std::vector<double> xs;                // the level's value on the figure's axis
    std::vector<std::string> level_names;  // the level's name in the table
    std::string name, section, xlabel;
    bool logx = false;
    std::string title;
};

// The sweeps' population: the glossy bucket, or the classes a taxonomy declares [heavy].
struct SweepClasses {
    HeavyClasses heavy;
    std::string label;  // in the tables' words: "glossy" or "[heavy]"
};

SweepClasses sweep_classes(const StudyConfig& cfg) {
    if (cfg.taxonomy) return {heavy_classes(cfg), "[heavy]"};
    return {HeavyClasses{{gpu::BUCKET_GLOSSY}, ""}, "glossy"};
}

// The mean per-sample energy of the classes' slots summed (one slot: bucket_field's values themselves).
std::vector<double> classes_field(const Frame& f, const std::vector<uint32_t>& slots) {
    if (slots.empty()) return std::vector<double>(f.pixels.size(), 0.0);
    std::vector<double> v = bucket_field(f, slots.front());
    for (size_t i = 1; i < slots.size(); ++i) {
        const std::vector<double> o = bucket_field(f, slots[i]);
        for (size_t p = 0; p < v.size(); ++p) v[p] += o[p];
    }
    return v;
}

// ---- compute: per level the glossy-dominant population, its firefly ratios and split-half rho ----

struct SweepLevel {
    size_t glossy_px = 0;     // pixels the glossy bucket (a taxonomy's [heavy] classes) dominates
    double glossy_share = 0;  // their energy share in the reference
    bool measured = false;    // false: fewer than kMinGlossyPixels such pixels
    double median_firefly = 0, p90_firefly = 0, rho = 0;
};

SweepLevel sweep_level(StudyContext& ctx, const SceneVariant& variant, const std::vector<stats::Partition>& partitions,
                       const SweepClasses& classes) {
    const StudyConfig& cfg = ctx.cfg;
    const int S = cfg.sweep_seeds;
    SweepLevel lv;
    Frame ref = ctx.frames.get({variant, cfg.sweep_ref_spp, seeds::sweep_reference(), Estimator::Nee});
    Descriptor d = derive_descriptor(ref);
    std::vector<size_t> glossy;  // the pixels the classes dominate
    for (size_t p = 0; p < d.dominant.size(); ++p)
        if (d.dominant[p] < kBucketCount && classes.heavy.contains(d.dominant[p])) glossy.push_back(p);
    lv.glossy_px = glossy.size();
    const DescriptorSummary sm = summarize(ref, d);
    for (uint32_t slot : classes.heavy.slots) lv.glossy_share += sm.energy_share[slot];
    if (glossy.size() < kMinGlossyPixels) return lv;
    std::vector<std::vector<double>> g(S), m(S);
    for (int s = 0; s < S; ++s) {
        Frame f = ctx.frames.get({variant, cfg.sweep_spp, seeds::sweep(s), Estimator::Nee});
        auto gf = classes_field(f, classes.heavy.slots);
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
    lv.measured = true;
    lv.median_firefly = stats::median(ratios);
    lv.p90_firefly = stats::quantile(ratios, 0.9);
    lv.rho = stats::mean(rhos);
    return lv;
}

// ---- writer ----

void write_sweep(StudyOutput& out, const StudyConfig& cfg, const SweepSpec& spec, size_t partitions,
                 const std::vector<SweepLevel>& levels, const SweepClasses& classes) {
    const std::string& g = classes.label;
    Table t{spec.name,
            spec.title,
            {spec.xlabel, g + "-dominant px", g + " energy share", "median firefly", "p90 firefly",
             "split-half rho sigma^2"},
            {},
            ""};
    const std::string energy = cfg.taxonomy ? "of the energy of " + classes.heavy.declared + ", summed"
                                            : std::string("of the glossy bucket's energy");
    t.note = "Per level: " + g + "-dominant pixels of a " + std::to_string(cfg.sweep_ref_spp) +
             "-SPP reference; firefly ratio "
             "per pixel = max / mean over " +
             std::to_string(cfg.sweep_seeds) + " seeds (" + std::to_string(cfg.sweep_spp) + " SPP each) " + energy +
             "; split-half rho of sigma^2 over the same pixels (" + std::to_string(partitions) +
             " partitions). \"---\": fewer than 50 " + g + "-dominant pixels.";
    report::Figure fig{spec.name, spec.title, "", 2, {}};
    report::Panel pf, pr;
    pf.title = "firefly ratio over " + g + "-dominant pixels (median, p50-p90 band)";
    pf.xlabel = spec.xlabel;
    pf.ylabel = "max / mean";
    pf.logx = spec.logx;
    pr.title = "split-half rho of sigma^2 (" + g + "-dominant pixels)";
    pr.xlabel = spec.xlabel;
    pr.ylabel = "rho";
    pr.logx = spec.logx;
    pr.hlines.push_back({0.0, "", ":", "#888888"});
    report::Series sf{"median", {}, {}, {}, {}, "#D55E00", "o", "-", 0, 0, {}},
        sr{"", {}, {}, {}, {}, "#0072B2", "o", "-", 0, 0, {}};
    for (size_t v = 0; v < levels.size(); ++v) {
        const SweepLevel& lv = levels[v];
        std::vector<Cell> row{Cell::str(spec.level_names[v]), Cell::integer(static_cast<long long>(lv.glossy_px)),
                              Cell::pct(lv.glossy_share)};
        if (!lv.measured) {
            t.add({row[0], row[1], row[2], Cell::str("---"), Cell::str("---"), Cell::str("---")});
            continue;
        }
        t.add({row[0], row[1], row[2], Cell::num(lv.median_firefly, "%.2f"), Cell::num(lv.p90_firefly, "%.2f"),
               Cell::num(lv.rho, "%+.3f")});
        sf.x.push_back(spec.xs[v]);
        sf.y.push_back(lv.median_firefly);
        sf.lo.push_back(lv.median_firefly);  // the band's p50 is the median
        sf.hi.push_back(lv.p90_firefly);
        sr.x.push_back(spec.xs[v]);
        sr.y.push_back(lv.rho);
    }
    pf.series.push_back(sf);
    pr.series.push_back(sr);
    fig.panels = {pf, pr};
    out.table(spec.section, t,
              "narrow lobes should carry heavier per-pixel tails (larger firefly ratios); the split-half "
              "column shows whether sigma^2 agrees with itself on the " +
                  g + " pixels at that level.");
    out.figure(spec.section, fig,
               "left: firefly ratio against the level (band p50-p90); right: split-half rho of sigma^2 "
               "(levels with too few " +
                   g + " pixels are omitted).");
}

void run_sweep(StudyContext& ctx, const SweepSpec& spec) {
    const auto partitions = stats::random_halves(ctx.cfg.sweep_seeds, ctx.cfg.split_half_partitions, 0);
    const SweepClasses classes = sweep_classes(ctx.cfg);
    std::vector<SweepLevel> levels;
    for (const auto& variant : spec.variants) levels.push_back(sweep_level(ctx, variant, partitions, classes));
    write_sweep(ctx.out, ctx.cfg, spec, partitions.size(), levels, classes);
}

}  // namespace

void run_sweep_roughness(StudyContext& ctx) {
    std::vector<double> xs;
    for (const auto& a : ctx.cfg.sweep_alphas) xs.push_back(std::stod(a));
    run_sweep(ctx, {roughness_variants(ctx.cfg), xs, ctx.cfg.sweep_alphas, "sweep_roughness", "Roughness sweep",
                    "alpha", true, "Roughness sweep: lobe width versus the glossy heavy tail (fig:roughness-sweep)"});
}

void run_sweep_lights(StudyContext& ctx) {
    std::vector<double> xs;
    std::vector<std::string> names;
    for (int n : ctx.cfg.sweep_lights) {
        xs.push_back(n);
        names.push_back(std::to_string(n));
    }
    run_sweep(ctx, {light_variants(ctx.cfg), xs, names, "sweep_lights", "Light-count sweep", "lights", true,
                    "Light-count sweep at alpha 0.03 (energy-conserving lights)"});
}

}  // namespace vkmech
