// Time-to-quality (paper §6, docs/descriptor.md §5): per-pixel c(p) from independent renders
// on a doubling SPP grid against the seed-disjoint reference, right-censored
// at the cap; per-bucket medians in SPP and in milliseconds of render time on
// the device; Spearman of cost against each continuous component.
#include "stats/cost.hpp"
#include "experiments/study_context.hpp"
#include "stats/rank.hpp"

#include <cmath>

namespace vkmech {

using report::Cell;
using report::Table;

void run_cost(StudyContext& ctx) {
    const StudyConfig& cfg = ctx.cfg;
    const std::string sec = "Time-to-quality";
    const double cap = cfg.cost_spp.back();
    const std::vector<uint32_t> rows = {gpu::BUCKET_DIRECT,         gpu::BUCKET_DIFFUSE_INDIRECT,
                                        gpu::BUCKET_DELTA_MEDIATED, gpu::BUCKET_SPECULAR_DIRECT,
                                        gpu::BUCKET_GLOSSY,         gpu::BUCKET_EMITTER_DIRECT};

    Table spp_t{
        "cost_by_bucket", "Median time-to-quality per dominant bucket, SPP (tab:cost-by-bucket)", {"bucket"}, {}, ""};
    Table ms_t{"cost_by_bucket_ms",
               "Median time-to-quality per dominant bucket, milliseconds of render time on " + ctx.device,
               {"bucket"},
               {},
               ""};
    Table long_t{
        "cost_by_bucket_detail",
        "Time-to-quality per scene and bucket: population, median, censoring",
        {"scene", "bucket", "pixels", "median SPP", "lower bound", "censored", "median ms", "ms per SPP (image)"},
        {},
        ""};
    Table dim_t{"cost_perdim",
                "Spearman rho between time-to-quality and each continuous component (tab:cost-perdim)",
                {"dim"},
                {},
                ""};
    const std::string rule = "c(p) = the smallest SPP in {" +
                             [&] {
                                 std::string s;
                                 for (size_t i = 0; i < cfg.cost_spp.size(); ++i)
                                     s += (i ? ", " : "") + std::to_string(cfg.cost_spp[i]);
                                 return s;
                             }() +
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
    std::vector<std::vector<Cell>> spp_rows(rows.size()), ms_rows(rows.size());
    for (size_t i = 0; i < rows.size(); ++i) spp_rows[i] = ms_rows[i] = {Cell::str(kBucketNames[rows[i]])};
    const char* dims[] = {"depth", "caustic_frac", "inv_purity", "glossy_frac"};
    std::vector<std::vector<Cell>> dim_rows(4);
    for (int i = 0; i < 4; ++i) dim_rows[i] = {Cell::str(dims[i])};

    report::Figure fig{"cost_by_bucket", "Median time-to-quality per bucket", "", 1, {}};
    report::Panel panel;
    panel.kind = "bar";
    panel.title = "median c(p) per dominant bucket (hatched: censored, a lower bound)";
    fig.panel_size = std::make_pair(9.0, 4.0);
    panel.ylabel = "SPP";
    panel.logy = true;
    for (uint32_t b : rows) panel.categories.push_back(kBucketNames[b]);

    for (const auto& scene : cfg.scenes) {
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
        const double ms_per_spp = 1000.0 * seconds / spp_total;
        auto cost = stats::time_to_quality(cfg.cost_spp, lum, lum_mean_field(ref), cfg.cost_tau, 1e-4);

        report::Series series{scene.name, {}, {}, {}, {}, "", "", "", 0, 0, {}};
        for (size_t r = 0; r < rows.size(); ++r) {
            std::vector<double> c;
            std::vector<uint8_t> cens;
            for (size_t p = 0; p < d.dominant.size(); ++p)
                if (d.dominant[p] == rows[r]) {
                    c.push_back(cost.spp[p]);
                    cens.push_back(cost.censored[p]);
                }
            auto med = stats::censored_median(c, cens);
            if (med.n == 0) {
                spp_rows[r].push_back(Cell::str("---"));
                ms_rows[r].push_back(Cell::str("---"));
                series.y.push_back(NAN);
                series.lower_bound.push_back(false);
                continue;
            }
            std::string mark = med.lower_bound ? "≥" : "", dag = med.lower_bound ? "†" : "";
            spp_rows[r].push_back({mark + report::format("%.0f", med.value) + dag, report::format("%.9g", med.value)});
            ms_rows[r].push_back({mark + report::format("%.1f", med.value * ms_per_spp) + dag,
                                  report::format("%.9g", med.value * ms_per_spp)});
            long_t.add({Cell::str(scene.name), Cell::str(kBucketNames[rows[r]]),
                        Cell::integer(static_cast<long long>(med.n)), Cell::num(med.value, "%.0f"),
                        Cell::str(med.lower_bound ? "yes" : "no"), Cell::pct(med.censored_rate, 1),
                        Cell::num(med.value * ms_per_spp, "%.1f"), Cell::num(ms_per_spp, "%.2f")});
            series.y.push_back(med.value);
            series.lower_bound.push_back(med.lower_bound);
        }
        panel.series.push_back(series);

        // Cost versus the components (censored ranked above every observed value).
        for (int k = 0; k < 4; ++k) {
            std::vector<double> x, y;
            bool any = false;
            for (size_t p = 0; p < d.dominant.size(); ++p) {
                if (d.dominant[p] == kNoLabel) continue;
                double v = k == 0   ? d.depth[p]
                           : k == 1 ? d.caustic_frac[p]
                           : k == 2 ? 1.0 - d.purity[p]
                                    : d.glossy_frac[p];
                any |= v != 0.0;
                x.push_back(v);
                y.push_back(cost.censored[p] ? 2.0 * cap : cost.spp[p]);
            }
            dim_rows[k].push_back(any ? Cell::num(stats::spearman(x, y), "%+.2f") : Cell::str("n/a"));
        }
    }
    for (auto& r : spp_rows) spp_t.add(r);
    for (auto& r : ms_rows) ms_t.add(r);
    for (auto& r : dim_rows) dim_t.add(r);
    fig.panels.push_back(panel);
    ctx.out.table(sec, spp_t,
                  "how many samples a pixel of each bucket needs to get within 10% of the reference; a † entry "
                  "is where the continuous cost measurement saturates at the cap.");
    ctx.out.table(sec, ms_t, "the same medians as wall-clock time of whole-image rendering on this device.");
    ctx.out.table(sec, long_t,
                  "per scene and bucket: population, median, whether it is a lower bound, and the censoring rate.");
    ctx.out.table(sec, dim_t,
                  "whether any single continuous component would serve as a cost proxy (paper: none does stably).");
    ctx.out.figure(sec, fig,
                   "grouped bars: median cost per bucket, one colour per scene, log scale; hatched bars are censored "
                   "lower bounds.");
}

}  // namespace vkmech
