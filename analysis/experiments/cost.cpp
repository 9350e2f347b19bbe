// Time-to-quality (paper §6, docs/descriptor.md §5): per-pixel c(p) from independent renders
// on a doubling SPP grid against the seed-disjoint reference, right-censored
// at the cap; per-bucket medians in SPP and in milliseconds of render time on
// the device; Spearman of cost against each continuous component. With --taxonomy (docs/lpe.md) the
// rows are the taxonomy's classes, and each class's energy share replaces caustic_frac (a bucket's).
#include "stats/cost.hpp"
#include "experiments/study_context.hpp"
#include "stats/rank.hpp"

#include <cmath>
#include <optional>

namespace vkmech {

using report::Cell;
using report::Table;
namespace {

// The table rows' buckets, in order (a taxonomy's rows are its classes).
const std::vector<uint32_t> kCostBuckets = {gpu::BUCKET_DIRECT,         gpu::BUCKET_DIFFUSE_INDIRECT,
                                            gpu::BUCKET_DELTA_MEDIATED, gpu::BUCKET_SPECULAR_DIRECT,
                                            gpu::BUCKET_GLOSSY,         gpu::BUCKET_EMITTER_DIRECT};

// A continuous component of tab:cost-perdim: its name and its per-pixel field.
struct CostDim {
    std::string name;
    std::vector<double> value;
};

// depth, caustic_frac, inv_purity and glossy_frac; under a taxonomy depth, inv_purity, glossy_frac and each class's
// share of the pixel's energy but `other`'s, named "<class> share" (delta_mediated's is caustic_frac).
std::vector<CostDim> cost_dims(const Frame& ref, const Descriptor& d, const std::vector<StudyClass>& classes,
                               bool taxonomy) {
    const size_t P = d.dominant.size();
    std::vector<CostDim> dims{{"depth", {d.depth.begin(), d.depth.end()}}};
    std::vector<CostDim> shares;
    if (!taxonomy) shares.push_back({"caustic_frac", {d.caustic_frac.begin(), d.caustic_frac.end()}});
    for (size_t c = 0; taxonomy && c + 1 < classes.size(); ++c)
        shares.push_back({classes[c].name + " share", std::vector<double>(P, 0.0)});
    for (size_t p = 0; taxonomy && p < P; ++p) {
        const std::array<double, kBucketCount> share = slot_shares(ref.pixels[p]);
        for (size_t c = 0; c < shares.size(); ++c)  // in float, as derive_descriptor's caustic_frac
            shares[c].value[p] = static_cast<float>(share[classes[c].slot]);
    }
    std::vector<double> inv_purity(P);
    for (size_t p = 0; p < P; ++p) inv_purity[p] = 1.0 - d.purity[p];
    CostDim glossy{"glossy_frac", {d.glossy_frac.begin(), d.glossy_frac.end()}};
    if (!taxonomy) dims.insert(dims.end(), shares.begin(), shares.end());
    dims.push_back({"inv_purity", inv_purity});
    dims.push_back(glossy);
    if (taxonomy) dims.insert(dims.end(), shares.begin(), shares.end());
    return dims;
}

// ---- compute: per scene the censored median cost per bucket and the cost's rank correlations ----

struct CostScene {
    std::string name;
    double ms_per_spp = 0;                       // the cost renders' GPU time per SPP of the whole image
    std::vector<stats::CensoredMedian> medians;  // per class of the rows (n 0: no pixels)
    std::vector<std::string> dims;               // the continuous components (cost_dims)
    std::vector<std::optional<double>> dim_rho;  // per component; none: identically zero
};

// Cost versus one continuous component (censored ranked above every observed value).
std::optional<double> cost_rho(const Descriptor& d, const stats::CostMap& cost, const std::vector<double>& dim,
                               double cap) {
    std::vector<double> x, y;
    bool any = false;
    for (size_t p = 0; p < d.dominant.size(); ++p) {
        if (d.dominant[p] == kNoLabel) continue;
        const double v = dim[p];
        any |= v != 0.0;
        x.push_back(v);
        y.push_back(cost.censored[p] ? 2.0 * cap : cost.spp[p]);
    }
    if (!any) return std::nullopt;
    return stats::spearman(x, y);
}

CostScene cost_scene(StudyContext& ctx, const SceneVariant& scene, const std::vector<StudyClass>& classes) {
    const StudyConfig& cfg = ctx.cfg;
    CostScene r;
    r.name = scene.name;
    Frame ref = ctx.frames.get(
        {scene, cfg.stability_reference_spp(), seeds::stability(cfg.stability_spp.size() - 1), Estimator::Nee});
    Descriptor d = derive_descriptor(ref);
    std::vector<std::vector<double>> lum;
    double seconds = 0, spp_total = 0;
    for (size_t l = 0; l < cfg.cost_spp.size(); ++l) {
        Frame f = ctx.frames.get({scene, cfg.cost_spp[l], seeds::cost(l), Estimator::Nee});
        lum.push_back(lum_mean_field(f));
        seconds += f.seconds;
        spp_total += cfg.cost_spp[l];
    }
    r.ms_per_spp = 1000.0 * seconds / spp_total;
    auto cost = stats::time_to_quality(cfg.cost_spp, lum, lum_mean_field(ref), cfg.cost_tau, 1e-4);
    for (const StudyClass& k : classes) {
        std::vector<double> c;
        std::vector<uint8_t> cens;
        for (size_t p = 0; p < d.dominant.size(); ++p)
            if (d.dominant[p] == k.slot) {
                c.push_back(cost.spp[p]);
                cens.push_back(cost.censored[p]);
            }
        r.medians.push_back(stats::censored_median(c, cens));
    }
    for (const CostDim& dim : cost_dims(ref, d, classes, cfg.taxonomy.has_value())) {
        r.dims.push_back(dim.name);
        r.dim_rho.push_back(cost_rho(d, cost, dim.value, cfg.cost_spp.back()));
    }
    return r;
}

struct CostResult {
    std::vector<StudyClass> classes;  // the rows
    std::vector<CostScene> scenes;
};

CostResult compute_cost(StudyContext& ctx) {
    CostResult r{study_classes(ctx.cfg, kCostBuckets), {}};
    for (const auto& scene : ctx.cfg.scenes) r.scenes.push_back(cost_scene(ctx, scene, r.classes));
    return r;
}

// ---- writers ----

// The class-by-scene tables of medians, in SPP and in milliseconds.
void add_median_rows(const CostResult& r, Table& spp_t, Table& ms_t) {
    for (size_t i = 0; i < r.classes.size(); ++i) {
        std::vector<Cell> spp_row{Cell::str(r.classes[i].name)}, ms_row = spp_row;
        for (const CostScene& sc : r.scenes) {
            const stats::CensoredMedian& med = sc.medians[i];
            if (med.n == 0) {
                spp_row.push_back(Cell::str("---"));
                ms_row.push_back(Cell::str("---"));
                continue;
            }
            std::string mark = med.lower_bound ? "≥" : "", dag = med.lower_bound ? "†" : "";
            spp_row.push_back({mark + report::format("%.0f", med.value) + dag, report::format("%.9g", med.value)});
            ms_row.push_back({mark + report::format("%.1f", med.value * sc.ms_per_spp) + dag,
                              report::format("%.9g", med.value * sc.ms_per_spp)});
        }
        spp_t.add(spp_row);
        ms_t.add(ms_row);
    }
}

Table detail_table(const CostResult& r, const std::string& label) {
    Table long_t{"cost_by_bucket_detail",
                 "Time-to-quality per scene and " + label + ": population, median, censoring",
                 {"scene", label, "pixels", "median SPP", "lower bound", "censored", "median ms", "ms per SPP (image)"},
                 {},
                 ""};
    for (const CostScene& sc : r.scenes)
        for (size_t i = 0; i < r.classes.size(); ++i) {
            const stats::CensoredMedian& med = sc.medians[i];
            if (med.n == 0) continue;
            long_t.add({Cell::str(sc.name), Cell::str(r.classes[i].name), Cell::integer(static_cast<long long>(med.n)),
                        Cell::num(med.value, "%.0f"), Cell::str(med.lower_bound ? "yes" : "no"),
                        Cell::pct(med.censored_rate, 1), Cell::num(med.value * sc.ms_per_spp, "%.1f"),
                        Cell::num(sc.ms_per_spp, "%.2f")});
        }
    return long_t;
}

report::Figure cost_figure(const CostResult& r, const std::string& label) {
    report::Figure fig{"cost_by_bucket", "Median time-to-quality per " + label, "", 1, {}};
    report::Panel panel;
    panel.kind = "bar";
    panel.title = "median c(p) per dominant " + label + " (hatched: censored, a lower bound)";
    fig.panel_size = std::make_pair(9.0, 4.0);
    panel.ylabel = "SPP";
    panel.logy = true;
    for (const StudyClass& c : r.classes) panel.categories.push_back(c.name);
    for (const CostScene& sc : r.scenes) {
        report::Series series{sc.name, {}, {}, {}, {}, "", "", "", 0, 0, {}};
        for (const stats::CensoredMedian& med : sc.medians) {
            series.y.push_back(med.n == 0 ? NAN : med.value);
            series.lower_bound.push_back(med.n == 0 ? false : med.lower_bound);
        }
        panel.series.push_back(series);
    }
    fig.panels.push_back(panel);
    return fig;
}

void write_cost(StudyOutput& out, const StudyConfig& cfg, const std::string& device, const CostResult& r) {
    const std::string sec = "Time-to-quality";
    const std::string label = cfg.taxonomy ? "class" : "bucket";
    Table spp_t{"cost_by_bucket",
                "Median time-to-quality per dominant " + label + ", SPP (tab:cost-by-bucket)",
                {label},
                {},
                ""};
    Table ms_t{"cost_by_bucket_ms",
               "Median time-to-quality per dominant " + label + ", milliseconds of render time on " + device,
               {label},
               {},
               ""};
    Table dim_t{"cost_perdim",
                "Spearman rho between time-to-quality and each continuous component (tab:cost-perdim)",
                {"dim"},
                {},
                ""};
    std::string levels;
    for (size_t i = 0; i < cfg.cost_spp.size(); ++i) levels += (i ? ", " : "") + std::to_string(cfg.cost_spp[i]);
    const std::string rule = "c(p) = the smallest SPP in {" + levels +
                             "} (independent renders) with |lum - lum_ref| / max(lum_ref, 1e-4) < " +
                             report::format("%.2f", cfg.cost_tau) + " against the " +
                             std::to_string(cfg.stability_reference_spp()) +
                             "-SPP seed-disjoint reference; otherwise right-censored. ";
    spp_t.note = rule +
                 "\"---\": no pixels; \"≥N†\": the median is censored, a lower bound (censoring rates in "
                 "cost_by_bucket_detail).";
    ms_t.note =
        "The SPP median times the measured wall time of one SPP over the whole image on this device (the cost "
        "renders' total GPU time / total SPP): what reaching the quality costs when a whole frame is rendered.";
    dim_t.note =
        "Over the reference's labelled pixels; censored pixels rank above every observed cost (tied). n/a: the "
        "component is identically zero in the scene.";
    for (const auto& s : cfg.scenes) {
        spp_t.columns.push_back(s.name);
        ms_t.columns.push_back(s.name);
        dim_t.columns.push_back(s.name);
    }
    add_median_rows(r, spp_t, ms_t);
    for (size_t k = 0; !r.scenes.empty() && k < r.scenes.front().dims.size(); ++k) {
        std::vector<Cell> row{Cell::str(r.scenes.front().dims[k])};
        for (const CostScene& sc : r.scenes)
            row.push_back(sc.dim_rho[k] ? Cell::num(*sc.dim_rho[k], "%+.2f") : Cell::str("n/a"));
        dim_t.add(row);
    }
    if (cfg.taxonomy)
        out.text(sec, "Classes: the taxonomy `" + cfg.taxonomy->file +
                          "` (docs/lpe.md); the rows are its classes, and each class's share of a pixel's energy "
                          "(\"<class> share\") is a component where the built-in study has caustic_frac.");
    out.table(sec, spp_t,
              "how many samples a pixel of each " + label +
                  " needs to get within 10% of the reference; a † entry "
                  "is where the continuous cost measurement saturates at the cap.");
    out.table(sec, ms_t, "the same medians as wall-clock time of whole-image rendering on this device.");
    out.table(sec, detail_table(r, label),
              "per scene and " + label + ": population, median, whether it is a lower bound, and the censoring rate.");
    out.table(sec, dim_t,
              "whether any single continuous component would serve as a cost proxy (paper: none does stably).");
    out.figure(sec, cost_figure(r, label),
               "grouped bars: median cost per " + label +
                   ", one colour per scene, log scale; hatched bars are censored lower bounds.");
}

}  // namespace

void run_cost(StudyContext& ctx) { write_cost(ctx.out, ctx.cfg, ctx.device, compute_cost(ctx)); }

}  // namespace vkmech
