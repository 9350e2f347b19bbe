#include "experiments/allocation.hpp"

#include "allocation/allocation.hpp"
#include "render/descriptor.hpp"
#include "shared/types.h"
#include "stats/rank.hpp"
#include "stats/summary.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <tuple>

namespace vkmech {

using report::Cell;
using report::Table;

namespace {

using alloc::Strategy;

double lum_of(double r, double g, double b) { return gpu::LUM_R * r + gpu::LUM_G * g + gpu::LUM_B * b; }

// Per-scene data the evaluations share.
struct SceneData {
    size_t P = 0;
    int w = 0, h = 0;
    std::vector<double> ref_rgb, ref_lum;  // unclamped linear RGB (docs/descriptor.md §6)
    std::vector<double> ref_rgb_clamped;   // clamped to [0, 1]: the display-range figures beside them
    double peak = 1.0;                     // the reference's largest RGB value: the PSNR peak
    std::vector<uint8_t> ref_labels;
    SamplePool pool;
    std::map<uint32_t, std::vector<Pilot>> pilots;                     // N0 -> draws
    std::map<uint32_t, std::vector<alloc::PilotDiagnosis>> diagnoses;  // N0 -> the draws' diagnoses (§6.5)
};

// The strategy inputs of pilot draw k at N0 (the oracle and the reference labels, for the controls).
alloc::ScoreInputs pilot_inputs(const SceneData& d, uint32_t n0, uint32_t k) {
    const Pilot& pl = d.pilots.at(n0)[k];
    alloc::ScoreInputs in;
    in.pilot_var = &pl.var;
    in.pilot_labels = &pl.labels;
    in.oracle_var = &d.pool.oracle_var;
    in.reference_labels = &d.ref_labels;
    if (!pl.mom_var.empty()) in.mom_var = &pl.mom_var;
    in.untrusted = &d.diagnoses.at(n0)[k].untrusted_map;
    in.pilot_spp = n0;
    return in;
}

// Errors of one final image against the reference. Primary: unclamped linear
// RGB (MSE; relative MSE (x - r)^2 / (r^2 + 0.01); p99 of the absolute
// luminance error; per-bucket MSE). Beside them, never instead: the MSE on
// RGB clamped to [0, 1], which caps the heavy-tailed errors.
struct Errors {
    double mse = 0, rel_mse = 0, p99 = 0, mse_clamped = 0;
    std::array<double, kBucketCount> bucket_mse{};
};

// The final image of an allocation: per pixel the mean of the first n(p) pool frames.
Errors evaluate(const SceneData& d, const std::vector<uint32_t>& n) {
    std::vector<double> lum(d.P);
    double se = 0, rel = 0, se_clamped = 0;
    std::array<double, kBucketCount> bse{}, bn{};
    const std::vector<double> img = final_image_rgb(d.pool, n);
    for (size_t p = 0; p < d.P; ++p) {
        const double* v = &img[3 * p];
        double e = 0;
        for (int c = 0; c < 3; ++c) {
            const double r = d.ref_rgb[3 * p + c];
            const double diff = v[c] - r;
            e += diff * diff / 3.0;
            rel += diff * diff / (r * r + 1e-2) / 3.0;
            const double dc = std::clamp(v[c], 0.0, 1.0) - d.ref_rgb_clamped[3 * p + c];
            se_clamped += dc * dc / 3.0;
        }
        lum[p] = lum_of(v[0], v[1], v[2]);
        se += e;
        if (d.ref_labels[p] != kNoLabel) {
            bse[d.ref_labels[p]] += e;
            bn[d.ref_labels[p]] += 1;
        }
    }
    Errors out;
    out.mse = se / d.P;
    out.rel_mse = rel / d.P;
    out.mse_clamped = se_clamped / d.P;
    out.p99 = alloc::p99_abs_error(lum, d.ref_lum);
    for (uint32_t b = 0; b < kBucketCount; ++b) out.bucket_mse[b] = bn[b] > 0 ? bse[b] / bn[b] : NAN;
    return out;
}

// Plot colours (Okabe-Ito), one per strategy that appears in a figure.
const std::map<Strategy, std::string> kStrategyColors = {
    {Strategy::Uniform, "#777777"},   {Strategy::ObservedVar, "#D55E00"}, {Strategy::BucketFloor, "#0072B2"},
    {Strategy::Oracle, "#009E73"},    {Strategy::Guarded, "#CC79A7"},     {Strategy::Shrink, "#E69F00"},
    {Strategy::RobustVar, "#56B4E9"}, {Strategy::RobustFloor, "#000000"}, {Strategy::RobustAdaptive, "#F0E442"},
};

struct Key {
    uint32_t n0, floor, extra;
    Strategy s;
    bool operator<(const Key& o) const { return std::tie(n0, floor, extra, s) < std::tie(o.n0, o.floor, o.extra, o.s); }
};

}  // namespace

std::vector<Strategy> allocation_timed_strategies(uint32_t n0) {
    std::vector<Strategy> timed = {Strategy::Uniform, Strategy::ObservedVar, Strategy::BucketFloor, Strategy::Guarded,
                                   Strategy::Shrink};
    if (alloc::mom_defined(static_cast<int>(n0)))
        timed.insert(timed.end(), {Strategy::RobustVar, Strategy::RobustFloor, Strategy::RobustAdaptive});
    return timed;
}

std::vector<Strategy> allocation_equal_time_strategies(uint32_t n0) {
    if (alloc::mom_defined(static_cast<int>(n0)))
        return {Strategy::Uniform, Strategy::ObservedVar, Strategy::RobustVar, Strategy::RobustFloor,
                Strategy::RobustAdaptive};
    return {Strategy::Uniform, Strategy::ObservedVar, Strategy::BucketFloor, Strategy::Guarded, Strategy::Shrink};
}

void run_allocation(AllocationContext& a) {
    const StudyConfig& cfg = a.cfg;
    const std::string sec = "Downstream allocation";
    const uint32_t n0_main = cfg.alloc_pilots.front();
    const uint32_t K = static_cast<uint32_t>(cfg.alloc_draws);
    const std::vector<Strategy> base = {Strategy::Uniform, Strategy::ObservedVar, Strategy::BucketFloor,
                                        Strategy::Oracle,  Strategy::Placebo,     Strategy::LabelOracle};
    const std::vector<Strategy> robust = {Strategy::RobustVar, Strategy::RobustFloor, Strategy::RobustPlacebo,
                                          Strategy::RobustAdaptive};
    const std::vector<Strategy> beyond = {Strategy::Guarded, Strategy::Shrink};  // not in the paper (§6.5, §6.6)
    Table beyond_t{"beyond_floor",
                   "Strategies beyond the paper: guarded (§6.5) and shrink (§6.6), floor 1",
                   {"scene", "N0", "untrusted px", "uniform", "obs-var", "b-floor", "guarded", "shrink", "placebo",
                    "MSE wins guarded vs b-floor", "MSE wins shrink vs obs-var"},
                   {},
                   ""};
    Table beyond_f4_t = beyond_t;
    beyond_f4_t.name = "beyond_floor_f4";
    beyond_f4_t.title = "Strategies beyond the paper: guarded (§6.5) and shrink (§6.6), the f = 4 sample-floor control";
    Table adaptive_t{"robust_adaptive",
                     "The per-bucket adaptive median-of-means block count (robust-adaptive, §6.7) "
                     "against the other strategies at equal samples",
                     {"scene", "N0", "floor", "rare-tail px", "uniform", "obs-var", "b-floor", "robust-var",
                      "robust-floor", "placebo", "robust-placebo", "robust-adaptive", "MSE wins r-adaptive vs r-var",
                      "MSE wins r-adaptive vs obs-var", "MSE wins r-adaptive vs r-floor"},
                     {},
                     ""};

    Table main_t{"downstream",
                 "",
                 {"scene", "uniform", "obs-var", "b-floor", "oracle", "label-oracle", "placebo", "MSE wins", "p99 wins",
                  "seed std obs/b-floor (dB)"},
                 {},
                 ""};
    Table f4_t = main_t;
    Table robust_t{"robust_alloc",
                   "Robust-variance incumbent at the pilots where median-of-means is defined (tab:robust-alloc)",
                   {"scene", "N0", "obs-var", "robust-var", "robust-floor", "robust-placebo", "b-floor",
                    "MSE wins r-floor vs r-var", "placebo dB vs obs-var", "b-floor dB vs obs-var", "robust-adaptive",
                    "MSE wins r-adaptive vs r-var"},
                   {},
                   ""};
    Table rel_t{"downstream_relmse",
                "Relative MSE at pilot N0 = " + std::to_string(n0_main) + ", floor 1 (unclamped linear RGB)",
                {"scene", "uniform", "obs-var", "b-floor", "oracle", "label-oracle", "placebo", "relMSE wins"},
                {},
                ""};
    Table clamped_t{"downstream_clamped",
                    "Clamped display-range PSNR at pilot N0 = " + std::to_string(n0_main) +
                        ", floor 1 (RGB clamped to [0, 1]; beside tab:downstream, not instead)",
                    {"scene", "uniform", "obs-var", "b-floor", "oracle", "label-oracle", "placebo", "clamped MSE wins"},
                    {},
                    ""};
    Table peak_t{"downstream_peak",
                 "The PSNR peak of each scene: the reference's largest linear RGB value",
                 {"scene", "peak"},
                 {},
                 ""};
    std::string oracle_fail;
    Table all_t{
        "downstream_all",
        "Every configuration: PSNR (dB, unclamped, reference peak) mean and seed std, MSE, relative "
        "MSE and p99 error on unclamped linear RGB, the clamped PSNR beside them, paired wins against observed-var",
        {"scene", "N0", "floor", "extra SPP", "strategy", "PSNR", "PSNR std", "MSE", "rel MSE", "p99 |lum err|",
         "PSNR clamped", "MSE wins vs obs-var"},
        {},
        ""};
    Table bucket_t{
        "perbucket_mse",
        "Per-bucket MSE (unclamped linear RGB) at N0 = " + std::to_string(n0_main) + " (buckets of the reference)",
        {"scene", "bucket", "pixels", "obs-var", "b-floor", "b-floor / obs-var"},
        {},
        ""};
    Table timing_t{"alloc_time",
                   "Wall time of each strategy on " + a.device + ": pilot + allocation + final render",
                   {"scene", "N0", "strategy", "pilot s", "allocation ms", "final s", "total s", "PSNR"},
                   {},
                   ""};
    Table eq_t{"equal_time",
               "Error versus wall-clock time (N0 = " + std::to_string(n0_main) + ", floor 1)",
               {"scene", "strategy", "extra SPP", "seconds", "PSNR"},
               {},
               ""};
    // The robust strategies need a pilot where median-of-means is defined: their equal-time table is at the first such
    // N0.
    uint32_t n0_robust = 0;
    for (uint32_t n0 : cfg.alloc_pilots)
        if (n0_robust == 0 && alloc::mom_defined(static_cast<int>(n0))) n0_robust = n0;
    Table eq_robust_t{"equal_time_robust",
                      "Error versus wall-clock time of the median-of-means strategies (N0 = " +
                          std::to_string(n0_robust) + ", floor 1)",
                      eq_t.columns,
                      {},
                      ""};
    report::Figure fig_pilot{
        "psnr_vs_pilot", "Equal-budget PSNR versus pilot budget (mean and seed std over draws)", "", 0, {}};
    report::Figure fig_budget{
        "psnr_vs_budget", "PSNR versus extra budget at N0 = " + std::to_string(n0_main), "", 0, {}};
    Table mom_t{"mom_sweep",
                "Median-of-means block-count sweep: robust-var and robust-floor PSNR against the block count k",
                {"scene", "N0", "k", "block size", "robust-var", "robust-floor", "floor - var (dB)",
                 "MSE wins r-floor vs r-var"},
                {},
                ""};
    Table rank_t{"mom_rank_fidelity",
                 "Within-bucket rank fidelity of the pilot variance against the pool's converged variance",
                 {"scene", "N0", "bucket", "pixels", "naive"},
                 {},
                 ""};
    for (int k : cfg.alloc_mom_k) rank_t.columns.push_back("MoM k=" + std::to_string(k));
    report::Figure fig_mom{"psnr_vs_mom_k", "PSNR versus the median-of-means block count k", "", 0, {}};
    report::Figure fig_time{
        "error_vs_time", "PSNR versus wall-clock seconds (pilot + allocation + final render)", "", 0, {}};
    report::Figure fig_time_robust{"error_vs_time_robust",
                                   "PSNR versus wall-clock seconds of the median-of-means "
                                   "strategies at N0 = " +
                                       std::to_string(n0_robust),
                                   "",
                                   0,
                                   {}};
    std::string fail_heavy, tie_note;
    bool cubes_tie = true, saw_cubes = false;

    for (const auto& scene : cfg.scenes) {
        SceneData d;
        // Independent reference (docs/descriptor.md §4: chunks of seeds 900000 + c, merged).
        const Frame ref = a.source.reference(scene);
        d.w = ref.width;
        d.h = ref.height;
        d.P = static_cast<size_t>(d.w) * d.h;
        // The mean over all samples taken (a non-finite one counts out, as in the final images).
        d.ref_rgb = mean_rgb(ref);
        d.ref_rgb_clamped.resize(3 * d.P);
        d.ref_lum.resize(d.P);
        for (size_t i = 0; i < 3 * d.P; ++i) d.ref_rgb_clamped[i] = std::clamp(d.ref_rgb[i], 0.0, 1.0);
        for (size_t p = 0; p < d.P; ++p)
            d.ref_lum[p] = lum_of(d.ref_rgb[3 * p], d.ref_rgb[3 * p + 1], d.ref_rgb[3 * p + 2]);
        d.peak = psnr_peak(d.ref_rgb);
        d.ref_labels = derive_descriptor(ref).dominant;

        // The pool, then K disjoint pilot draws per N0 (median-of-means blocks where defined).
        d.pool = a.source.pool(scene);
        if (d.pool.pixels != d.P || d.pool.frames < downstream_seeds::kPoolSize)
            throw std::runtime_error("allocation study: the pool of " + scene.name + " has " +
                                     std::to_string(d.pool.frames) + " frames of " + std::to_string(d.pool.pixels) +
                                     " pixels; the reference has " + std::to_string(d.P) + " pixels and " +
                                     std::to_string(downstream_seeds::kPoolSize) + " frames are needed");
        for (uint32_t n0 : cfg.alloc_pilots)
            for (uint32_t k = 0; k < K; ++k) {
                Pilot p = a.source.pilot(scene, n0, k);
                if (p.var.size() != d.P)
                    throw std::runtime_error("allocation study: pilot " + std::to_string(k) + " of " + scene.name +
                                             " has " + std::to_string(p.var.size()) + " pixels, not " +
                                             std::to_string(d.P));
                d.diagnoses[n0].push_back(alloc::diagnose_pilot(p));
                d.pilots[n0].push_back(std::move(p));
            }

        // Every configuration, every draw.
        std::map<Key, std::vector<Errors>> res;
        std::map<Key, std::vector<std::vector<uint32_t>>> allocs;  // draw 0 allocations, for the timing renders
        auto run_config = [&](uint32_t n0, uint32_t floor, uint32_t extra, Strategy s) {
            Key key{n0, floor, extra, s};
            if (res.count(key)) return;
            for (uint32_t k = 0; k < K; ++k) {
                AdaptivePlan plan = plan_allocation(s, pilot_inputs(d, n0, k), extra, floor,
                                                    7919u * (k + 1));  // placebo: fresh per draw
                res[key].push_back(evaluate(d, plan.n));
                if (k == 0) allocs[key].push_back(plan.n);
            }
        };
        for (uint32_t n0 : cfg.alloc_pilots)
            for (uint32_t floor : cfg.alloc_floors) {
                for (Strategy s : base) run_config(n0, floor, cfg.alloc_extra, s);
                for (Strategy s : beyond) run_config(n0, floor, cfg.alloc_extra, s);
                if (alloc::mom_defined(static_cast<int>(n0)))
                    for (Strategy s : robust) run_config(n0, floor, cfg.alloc_extra, s);
            }
        for (uint32_t extra : cfg.alloc_budget_sweep)
            for (Strategy s : {Strategy::Uniform, Strategy::ObservedVar, Strategy::BucketFloor, Strategy::Oracle})
                run_config(n0_main, 1, extra, s);

        auto per_draw = [&](const Key& k, double Errors::*field) {
            std::vector<double> v;
            for (const auto& e : res.at(k)) v.push_back(e.*field);
            return v;
        };
        auto psnrs = [&](const Key& k) {  // unclamped linear RGB, peak = the reference's largest value
            std::vector<double> v;
            for (const auto& e : res.at(k)) v.push_back(alloc::psnr(e.mse, d.peak));
            return v;
        };
        auto psnrs_clamped = [&](const Key& k) {  // RGB clamped to [0, 1], peak 1
            std::vector<double> v;
            for (const auto& e : res.at(k)) v.push_back(alloc::psnr(e.mse_clamped));
            return v;
        };
        auto mses = [&](const Key& k, bool p99) { return per_draw(k, p99 ? &Errors::p99 : &Errors::mse); };
        auto psnr_cell = [&](const Key& k) { return Cell::num(stats::mean(psnrs(k)), "%.2f"); };
        // Paired MSE wins of configuration k over the same configuration with strategy `against`; "tie" when identical.
        auto wins_cell = [&](const Key& k, Strategy against) {
            const auto ma = mses(k, false), mb = mses({k.n0, k.floor, k.extra, against}, false);
            if (ma == mb) return Cell::str("tie");
            const auto w = alloc::paired_wins(ma, mb);
            return Cell::str(std::to_string(w.wins) + "/" + std::to_string(w.draws));
        };
        bool heavy = false;
        for (uint8_t l : d.ref_labels) heavy |= alloc::is_heavy_tailed(l);

        auto main_row = [&](uint32_t floor) {
            std::vector<Cell> row{Cell::str(scene.name)};
            for (Strategy s : {Strategy::Uniform, Strategy::ObservedVar, Strategy::BucketFloor, Strategy::Oracle,
                               Strategy::LabelOracle, Strategy::Placebo})
                row.push_back(psnr_cell({n0_main, floor, cfg.alloc_extra, s}));
            Key bf{n0_main, floor, cfg.alloc_extra, Strategy::BucketFloor},
                ov{n0_main, floor, cfg.alloc_extra, Strategy::ObservedVar};
            auto wm = alloc::paired_wins(mses(bf, false), mses(ov, false));
            auto wp = alloc::paired_wins(mses(bf, true), mses(ov, true));
            bool identical = mses(bf, false) == mses(ov, false);
            row.push_back(Cell::str(identical ? "tie" : std::to_string(wm.wins) + "/" + std::to_string(wm.draws)));
            row.push_back(Cell::str(identical ? "tie" : std::to_string(wp.wins) + "/" + std::to_string(wp.draws)));
            double lo = INFINITY, hi = 0;
            for (Strategy s : {Strategy::ObservedVar, Strategy::BucketFloor}) {  // uniform does not depend on the pilot
                double sd = std::sqrt(stats::sample_variance(psnrs({n0_main, floor, cfg.alloc_extra, s})));
                lo = std::min(lo, sd);
                hi = std::max(hi, sd);
            }
            row.push_back(Cell::str(report::format("%.2f", lo) + "-" + report::format("%.2f", hi)));
            if (floor == 1) {
                if (scene.name == "cubes_dof") {
                    saw_cubes = true;
                    cubes_tie = identical;
                }
                if (heavy && !identical && wm.wins < static_cast<int>((7 * K + 9) / 10))
                    fail_heavy += (fail_heavy.empty() ? "" : ", ") + scene.name + " (" + std::to_string(wm.wins) + "/" +
                                  std::to_string(K) + ")";
                if (!heavy)
                    tie_note += (tie_note.empty() ? "" : ", ") + scene.name + (identical ? " (tie)" : " (no tie)");
            }
            return row;
        };
        main_t.add(main_row(1));
        {
            // Beside the primary table: relative MSE (lower is better) and the clamped display-range PSNR.
            std::vector<Cell> rrow{Cell::str(scene.name)}, crow{Cell::str(scene.name)};
            for (Strategy s : {Strategy::Uniform, Strategy::ObservedVar, Strategy::BucketFloor, Strategy::Oracle,
                               Strategy::LabelOracle, Strategy::Placebo}) {
                Key k{n0_main, 1, cfg.alloc_extra, s};
                rrow.push_back(Cell::num(stats::mean(per_draw(k, &Errors::rel_mse)), "%.4g"));
                crow.push_back(Cell::num(stats::mean(psnrs_clamped(k)), "%.2f"));
            }
            Key bf{n0_main, 1, cfg.alloc_extra, Strategy::BucketFloor},
                ov{n0_main, 1, cfg.alloc_extra, Strategy::ObservedVar};
            auto wr = alloc::paired_wins(per_draw(bf, &Errors::rel_mse), per_draw(ov, &Errors::rel_mse));
            auto wc = alloc::paired_wins(per_draw(bf, &Errors::mse_clamped), per_draw(ov, &Errors::mse_clamped));
            const bool tie = per_draw(bf, &Errors::mse) == per_draw(ov, &Errors::mse);
            rrow.push_back(Cell::str(tie ? "tie" : std::to_string(wr.wins) + "/" + std::to_string(wr.draws)));
            crow.push_back(Cell::str(tie ? "tie" : std::to_string(wc.wins) + "/" + std::to_string(wc.draws)));
            rel_t.add(rrow);
            clamped_t.add(crow);
            rrow.clear();
            const double pu = stats::mean(psnrs({n0_main, 1, cfg.alloc_extra, Strategy::Uniform}));
            const double po = stats::mean(psnrs({n0_main, 1, cfg.alloc_extra, Strategy::Oracle}));
            if (!(po > pu))
                oracle_fail += (oracle_fail.empty() ? "" : ", ") + scene.name + " (" + report::format("%.2f", po) +
                               " vs " + report::format("%.2f", pu) + " dB)";
            peak_t.add({Cell::str(scene.name), Cell::num(d.peak, "%.4g")});
        }
        if (std::find(cfg.alloc_floors.begin(), cfg.alloc_floors.end(), 4u) != cfg.alloc_floors.end())
            f4_t.add(main_row(4));

        for (uint32_t n0 : cfg.alloc_pilots) {
            if (!alloc::mom_defined(static_cast<int>(n0))) continue;
            auto m = [&](Strategy s) { return stats::mean(psnrs({n0, 1, cfg.alloc_extra, s})); };
            auto w = alloc::paired_wins(mses({n0, 1, cfg.alloc_extra, Strategy::RobustFloor}, false),
                                        mses({n0, 1, cfg.alloc_extra, Strategy::RobustVar}, false));
            robust_t.add({Cell::str(scene.name), Cell::integer(n0), Cell::num(m(Strategy::ObservedVar), "%.2f"),
                          Cell::num(m(Strategy::RobustVar), "%.2f"), Cell::num(m(Strategy::RobustFloor), "%.2f"),
                          Cell::num(m(Strategy::RobustPlacebo), "%.2f"), Cell::num(m(Strategy::BucketFloor), "%.2f"),
                          Cell::str(std::to_string(w.wins) + "/" + std::to_string(w.draws)),
                          Cell::num(m(Strategy::Placebo) - m(Strategy::ObservedVar), "%+.2f"),
                          Cell::num(m(Strategy::BucketFloor) - m(Strategy::ObservedVar), "%+.2f"),
                          Cell::num(m(Strategy::RobustAdaptive), "%.2f"),
                          wins_cell({n0, 1, cfg.alloc_extra, Strategy::RobustAdaptive}, Strategy::RobustVar)});
        }
        for (uint32_t floor : cfg.alloc_floors)
            for (uint32_t n0 : cfg.alloc_pilots) {
                auto m = [&](Strategy s) {
                    return Cell::num(stats::mean(psnrs({n0, floor, cfg.alloc_extra, s})), "%.2f");
                };
                auto wins = [&](Strategy s, Strategy against) {
                    return wins_cell({n0, floor, cfg.alloc_extra, s}, against);
                };
                double untrusted = 0.0;  // mean over the draws of the pilot's untrusted pixels
                for (const alloc::PilotDiagnosis& dg : d.diagnoses[n0]) untrusted += static_cast<double>(dg.untrusted);
                untrusted /= static_cast<double>(d.diagnoses[n0].size());
                if (floor == 1 || floor == alloc::kStudyControlFloor)
                    (floor == 1 ? beyond_t : beyond_f4_t)
                        .add({Cell::str(scene.name), Cell::integer(n0), Cell::num(untrusted, "%.1f"),
                              m(Strategy::Uniform), m(Strategy::ObservedVar), m(Strategy::BucketFloor),
                              m(Strategy::Guarded), m(Strategy::Shrink), m(Strategy::Placebo),
                              wins(Strategy::Guarded, Strategy::BucketFloor),
                              wins(Strategy::Shrink, Strategy::ObservedVar)});
                if (!alloc::mom_defined(static_cast<int>(n0))) continue;
                double rare = 0.0;  // mean over the draws of the pilot's rare-tail pixels (where k = 1)
                for (const Pilot& pl : d.pilots[n0]) rare += static_cast<double>(alloc::rare_tail_pixels(pl.labels));
                rare /= static_cast<double>(d.pilots[n0].size());
                adaptive_t.add({Cell::str(scene.name), Cell::integer(n0), Cell::integer(floor), Cell::num(rare, "%.1f"),
                                m(Strategy::Uniform), m(Strategy::ObservedVar), m(Strategy::BucketFloor),
                                m(Strategy::RobustVar), m(Strategy::RobustFloor), m(Strategy::Placebo),
                                m(Strategy::RobustPlacebo), m(Strategy::RobustAdaptive),
                                wins(Strategy::RobustAdaptive, Strategy::RobustVar),
                                wins(Strategy::RobustAdaptive, Strategy::ObservedVar),
                                wins(Strategy::RobustAdaptive, Strategy::RobustFloor)});
            }
        for (const auto& [k, errs] : res) {
            auto p = psnrs(k);
            auto w = alloc::paired_wins(mses(k, false), mses({k.n0, k.floor, k.extra, Strategy::ObservedVar}, false));
            bool has_ov = res.count({k.n0, k.floor, k.extra, Strategy::ObservedVar}) > 0;
            all_t.add({Cell::str(scene.name), Cell::integer(k.n0), Cell::integer(k.floor), Cell::integer(k.extra),
                       Cell::str(alloc::to_string(k.s)), Cell::num(stats::mean(p), "%.3f"),
                       Cell::num(std::sqrt(stats::sample_variance(p)), "%.3f"),
                       Cell::num(stats::mean(mses(k, false)), "%.4g"),
                       Cell::num(stats::mean(per_draw(k, &Errors::rel_mse)), "%.4g"),
                       Cell::num(stats::mean(mses(k, true)), "%.4g"), Cell::num(stats::mean(psnrs_clamped(k)), "%.3f"),
                       Cell::str(has_ov ? std::to_string(w.wins) + "/" + std::to_string(w.draws) : "")});
        }
        for (uint32_t b = 0; b < kBucketCount - 1; ++b) {
            size_t n = 0;
            for (uint8_t l : d.ref_labels) n += l == b;
            if (n == 0) continue;
            auto bm = [&](Strategy s) {
                std::vector<double> v;
                for (const auto& e : res.at({n0_main, 1, cfg.alloc_extra, s})) v.push_back(e.bucket_mse[b]);
                return stats::mean(v);
            };
            double o = bm(Strategy::ObservedVar), f = bm(Strategy::BucketFloor);
            bucket_t.add({Cell::str(scene.name), Cell::str(kBucketNames[b]), Cell::integer(static_cast<long long>(n)),
                          Cell::num(o, "%.4g"), Cell::num(f, "%.4g"), Cell::num(f / o, "%.3f")});
        }

        // Figures: PSNR vs pilot budget, PSNR vs extra budget.
        report::Panel pp, pb;
        pp.title = pb.title = scene.name;
        pp.xlabel = "pilot N0 (SPP)";
        pb.xlabel = "extra SPP per pixel";
        pp.ylabel = pb.ylabel = "PSNR (dB)";
        pp.logx = pb.logx = true;
        for (Strategy s : {Strategy::Uniform, Strategy::ObservedVar, Strategy::Oracle, Strategy::BucketFloor}) {
            const std::string& col = kStrategyColors.at(s);
            report::Series sp{
                alloc::to_string(s), {}, {}, {}, {}, col, "o", s == Strategy::Oracle ? "--" : "-", 0, 0, {}};
            report::Series sb = sp;
            for (uint32_t n0 : cfg.alloc_pilots) {
                auto p = psnrs({n0, 1, cfg.alloc_extra, s});
                double mu = stats::mean(p), sd = std::sqrt(stats::sample_variance(p));
                sp.x.push_back(n0);
                sp.y.push_back(mu);
                sp.lo.push_back(mu - sd);
                sp.hi.push_back(mu + sd);
            }
            for (uint32_t extra : cfg.alloc_budget_sweep) {
                auto p = psnrs({n0_main, 1, extra, s});
                double mu = stats::mean(p), sd = std::sqrt(stats::sample_variance(p));
                sb.x.push_back(extra);
                sb.y.push_back(mu);
                sb.lo.push_back(mu - sd);
                sb.hi.push_back(mu + sd);
            }
            pp.series.push_back(sp);
            pb.series.push_back(sb);
        }
        fig_pilot.panels.push_back(pp);
        fig_budget.panels.push_back(pb);

        // The median-of-means block-count sweep (paper §7 Result 3): at every pilot where MoM is defined, for every
        // block count k of the sweep, robust-var and robust-floor recomputed from the pilot's own samples, and the
        // rank fidelity of each variance estimate against the pool's converged variance within each reference bucket.
        report::Panel pm;
        pm.title = scene.name;
        pm.xlabel = "median-of-means block count k";
        pm.ylabel = "PSNR (dB)";
        for (uint32_t n0 : cfg.alloc_pilots) {
            if (!alloc::mom_defined(static_cast<int>(n0)) || cfg.alloc_mom_k.empty()) continue;
            std::vector<int> ks;
            for (int k : cfg.alloc_mom_k)
                if (k >= 1 && static_cast<int>(n0) / k >= 2) ks.push_back(k);
            std::map<int, std::vector<Errors>> ev, ef;  // k -> per-draw errors
            std::map<int, std::array<std::vector<double>, kBucketCount>>
                rho;  // k -> bucket -> per-draw rho (k 0: naive)
            std::array<std::vector<size_t>, kBucketCount> members;
            for (size_t p = 0; p < d.P; ++p)
                if (d.ref_labels[p] != kNoLabel) members[d.ref_labels[p]].push_back(p);
            auto fidelity = [&](int k, const std::vector<double>& v) {
                for (uint32_t b = 0; b < kBucketCount; ++b) {
                    if (members[b].size() < 50) continue;  // too few pixels for a rank correlation
                    std::vector<double> x, y;
                    for (size_t p : members[b]) {
                        x.push_back(v[p]);
                        y.push_back(d.pool.oracle_var[p]);
                    }
                    const double r = stats::spearman(x, y);  // NaN when one side is constant in this bucket
                    if (std::isfinite(r)) rho[k][b].push_back(r);
                }
            };
            for (uint32_t k = 0; k < K; ++k) {
                const Pilot& pl = d.pilots[n0][k];
                const PilotSamples ps = a.source.pilot_samples(scene, n0, k);
                if (ps.pixels != d.P || ps.samples != n0)
                    throw std::runtime_error("allocation study: the per-sample pilot " + std::to_string(k) + " of " +
                                             scene.name + " does not match its pilot");
                fidelity(0, pl.var);
                for (int kk : ks) {
                    const std::vector<double> mv = ps.mom_variance(kk);
                    fidelity(kk, mv);
                    alloc::ScoreInputs in = pilot_inputs(d, n0, k);
                    in.mom_var = &mv;
                    ev[kk].push_back(evaluate(d, plan_allocation(Strategy::RobustVar, in, cfg.alloc_extra, 1, 0).n));
                    ef[kk].push_back(evaluate(d, plan_allocation(Strategy::RobustFloor, in, cfg.alloc_extra, 1, 0).n));
                }
            }
            report::Series sv{
                "robust-var N0=" + std::to_string(n0), {}, {}, {}, {}, "#D55E00", "o", n0 == 16 ? "-" : "--", 0, 0, {}};
            report::Series sf{"robust-floor N0=" + std::to_string(n0),
                              {},
                              {},
                              {},
                              {},
                              "#0072B2",
                              "o",
                              n0 == 16 ? "-" : "--",
                              0,
                              0,
                              {}};
            for (int kk : ks) {
                std::vector<double> pv, pf, mv, mf;
                for (const Errors& e : ev[kk]) {
                    pv.push_back(alloc::psnr(e.mse, d.peak));
                    mv.push_back(e.mse);
                }
                for (const Errors& e : ef[kk]) {
                    pf.push_back(alloc::psnr(e.mse, d.peak));
                    mf.push_back(e.mse);
                }
                auto w = alloc::paired_wins(mf, mv);
                mom_t.add({Cell::str(scene.name), Cell::integer(n0), Cell::integer(kk),
                           Cell::integer(alloc::mom_block_size(static_cast<int>(n0), kk)),
                           Cell::num(stats::mean(pv), "%.2f"), Cell::num(stats::mean(pf), "%.2f"),
                           Cell::num(stats::mean(pf) - stats::mean(pv), "%+.2f"),
                           Cell::str(std::to_string(w.wins) + "/" + std::to_string(w.draws))});
                sv.x.push_back(kk);
                sv.y.push_back(stats::mean(pv));
                sf.x.push_back(kk);
                sf.y.push_back(stats::mean(pf));
            }
            pm.series.push_back(sv);
            pm.series.push_back(sf);
            for (uint32_t b = 0; b < kBucketCount; ++b) {
                if (rho[0][b].empty()) continue;
                std::vector<Cell> row{Cell::str(scene.name), Cell::integer(n0), Cell::str(kBucketNames[b]),
                                      Cell::integer(static_cast<long long>(members[b].size())),
                                      Cell::num(stats::mean(rho[0][b]), "%.3f")};
                for (int kk : cfg.alloc_mom_k)
                    row.push_back(rho.count(kk) && !rho[kk][b].empty() ? Cell::num(stats::mean(rho[kk][b]), "%.3f")
                                                                       : Cell::str(""));
                rank_t.add(row);
            }
        }
        if (!pm.series.empty()) fig_mom.panels.push_back(pm);

        // Wall time: the pilot's GPU time, the allocation, and a real GPU render of draw 0's n(p).
        auto final_seconds = [&](const std::vector<uint32_t>& n) { return a.source.final_render_seconds(scene, n); };
        for (uint32_t n0 : cfg.alloc_pilots) {
            for (Strategy s : allocation_timed_strategies(n0)) {
                const Pilot& pl = d.pilots[n0][0];
                AdaptivePlan plan = plan_allocation(s, pilot_inputs(d, n0, 0), cfg.alloc_extra, 1, 7919u);
                double fs_ = final_seconds(plan.n);
                timing_t.add({Cell::str(scene.name), Cell::integer(n0), Cell::str(alloc::to_string(s)),
                              Cell::num(pl.seconds, "%.3f"), Cell::num(plan.allocation_ms, "%.2f"),
                              Cell::num(fs_, "%.3f"), Cell::num(pl.seconds + plan.allocation_ms / 1000.0 + fs_, "%.3f"),
                              Cell::num(stats::mean(psnrs({n0, 1, cfg.alloc_extra, s})), "%.2f")});
            }
        }
        // Equal time: per strategy and extra budget, the mean PSNR over the draws against the measured seconds of
        // the mean pilot + draw 0's allocation + a real render of draw 0's n(p).
        auto equal_time = [&](uint32_t n0, Table& t, report::Figure& fig) {
            report::Panel pt;
            pt.title = scene.name;
            pt.xlabel = "wall-clock seconds (pilot + allocation + final render)";
            pt.ylabel = "PSNR (dB)";
            pt.logx = true;
            double pilot_s = 0;
            for (const auto& pl : d.pilots[n0]) pilot_s += pl.seconds / K;
            for (Strategy s : allocation_equal_time_strategies(n0)) {
                report::Series st{alloc::to_string(s), {}, {}, {}, {}, kStrategyColors.at(s), "o", "-", 0, 0, {}};
                for (uint32_t extra : cfg.equal_time_budgets) {
                    run_config(n0, 1, extra, s);
                    AdaptivePlan plan = plan_allocation(s, pilot_inputs(d, n0, 0), extra, 1, 7919u);
                    double secs = pilot_s + plan.allocation_ms / 1000.0 + final_seconds(plan.n);
                    double ps = stats::mean(psnrs({n0, 1, extra, s}));
                    t.add({Cell::str(scene.name), Cell::str(alloc::to_string(s)), Cell::integer(extra),
                           Cell::num(secs, "%.3f"), Cell::num(ps, "%.2f")});
                    st.x.push_back(secs);
                    st.y.push_back(ps);
                }
                pt.series.push_back(st);
            }
            fig.panels.push_back(pt);
        };
        if (cfg.equal_time) {
            equal_time(n0_main, eq_t, fig_time);
            if (n0_robust != 0) equal_time(n0_robust, eq_robust_t, fig_time_robust);
        }
    }

    const std::string n0s = std::to_string(n0_main), ex = std::to_string(cfg.alloc_extra);
    main_t.title = "Equal-budget allocation at pilot N0 = " + n0s + ", floor 1 (tab:downstream)";
    main_t.note =
        "PSNR (dB) on unclamped linear RGB, 10 log10(peak^2 / MSE) with the reference's largest RGB value as "
        "the peak (tables/downstream_peak.md), against an independent " +
        std::to_string(cfg.alloc_ref_chunks * cfg.alloc_ref_chunk_spp) + "-SPP reference, mean over " +
        std::to_string(K) +
        " disjoint pilot draws (the mean of the per-draw PSNRs, i.e. the PSNR of the geometric-mean "
        "MSE; a bad draw weighs less in dB than in MSE); every strategy spends exactly (1 + " +
        ex +
        ") x pixels samples of the shared 256-frame pool. MSE / p99 wins: draws in which bucket-floor has a "
        "lower MSE / 99th-percentile luminance error than observed-var; \"tie\": identical in every draw. The "
        "clamped display-range PSNR is in tab:downstream-clamped, beside this one.";
    rel_t.note =
        "Mean over the draws of the relative MSE (x - r)^2 / (r^2 + 0.01) per pixel and channel, unclamped; "
        "relMSE wins: draws in which bucket-floor's relative MSE is below observed-var's. The 0.01 keeps "
        "black pixels finite: where r is well below 0.1 the figure is close to 100 x the absolute squared "
        "error, so in a dim scene this table ranks much as the MSE does.";
    clamped_t.note =
        "RGB clamped to [0, 1] (exposure 1) on both sides, peak 1. Clamping caps exactly the heavy-tailed "
        "errors the strategies exist to repair (a caustic or firefly pixel far above 1 counts as 1), so "
        "these figures are reported beside the unclamped ones, never instead.";
    f4_t.name = "downstream_f4";
    f4_t.title = "The f = 4 sample-floor control at N0 = " + n0s + " (tab:downstream-f4)";
    f4_t.note =
        "As tab:downstream with every pixel guaranteed 4 samples, deducted from the Neyman share (totals unchanged).";
    robust_t.note =
        "Median-of-means over k = ceil(sqrt(N0)) contiguous blocks of the pilot (per-block ddof 1, remainder "
        "discarded); not defined at N0 = 4. Placebo / b-floor columns: PSNR gain over observed-var of the "
        "shuffled-label floor and of the real one — the gain specific to the label is the difference. robust-adaptive "
        "(§6.7): k chosen per pilot label, its wins against robust-var (\"tie\": identical in every draw).";
    timing_t.note =
        "Measured on this device for pilot draw 0 (GPU times vary run to run; the error columns do not). The "
        "final render is the GPU adaptive render of the strategy's n(p).";
    eq_t.note =
        "Each point: the mean PSNR over the draws at one extra budget, against the measured wall time of pilot + "
        "allocation + final render.";
    a.out.table(sec, main_t,
                "higher is better; the paper's claim is that bucket-floor beats observed-var in most draws "
                "wherever heavy-tailed buckets exist, and ties it exactly where they do not (cubes_dof).");
    if (!f4_t.rows.empty())
        a.out.table(sec, f4_t,
                    "the same with a shared floor of 4 samples: what a plain sample floor repairs on its own.");
    if (!robust_t.rows.empty())
        a.out.table(sec, robust_t,
                    "whether a robust variance estimator already does what the label does; the placebo "
                    "column is the gain any partition would give.");
    a.out.table(sec, rel_t,
                "lower is better: the error relative to the reference's own brightness (for pixels brighter "
                "than about 0.1), so bright caustics do not dominate it as they dominate the MSE.");
    a.out.table(sec, clamped_t,
                "the display-range view of the same images: where it disagrees with tab:downstream, the "
                "difference sits in pixels brighter than 1.");
    a.out.table(sec, peak_t, "the peak each scene's PSNR is taken against.");
    a.out.table(sec, bucket_t, "where bucket-floor's gain or loss lands, by the reference's dominant bucket.");
    beyond_t.note =
        "PSNR (dB, unclamped, reference peak), mean over the draws, at every pilot N0, floor 1, extra budget " + ex +
        ". untrusted px: the pilot's untrusted pixels (§6.5), mean over the draws. guarded: bucket-floor "
        "with at least the uniform share on them; shrink: the pilot variance shrunk on the log scale towards "
        "its label's empirical-Bayes prior. Wins: draws with the lower MSE; \"tie\": identical in every draw.";
    a.out.table(sec, beyond_t,
                "whether the two strategies that go past the paper help: guarded should matter only where "
                "the pilot leaves untrusted pixels, shrink most at the shortest pilot.");
    if (!beyond_f4_t.rows.empty()) {
        beyond_f4_t.note = "As tab:beyond_floor with every pixel guaranteed " +
                           std::to_string(alloc::kStudyControlFloor) +
                           " samples, deducted from the Neyman share (totals unchanged).";
        a.out.table(sec, beyond_f4_t,
                    "the same with a shared floor of 4 samples: whether guarded and shrink still help "
                    "once a plain sample floor protects every pixel.");
    }
    if (!adaptive_t.rows.empty()) {
        adaptive_t.note = "PSNR (dB, unclamped, reference peak), mean over the draws, extra budget " + ex +
                          ", at every pilot where median-of-means is defined and every floor. robust-adaptive: the "
                          "plain pilot variance (k = 1) on pixels whose pilot label is delta_mediated or "
                          "specular_direct, robust-var's median-of-means (k = ceil(sqrt(N0))) everywhere else, "
                          "unlabelled pixels included (§6.7); the rule was fixed a priori, not fitted to these scenes. "
                          "rare-tail px: the pilot's pixels where k = 1, mean over the draws (0: robust-adaptive is "
                          "robust-var bit for bit). Wins: draws with the lower MSE; \"tie\": identical in every draw.";
        a.out.table(sec, adaptive_t,
                    "whether choosing the block count per pilot label beats one block count for every "
                    "pixel (robust-var), the label's floor (robust-floor) and the plain variance; the "
                    "placebo columns are the gain of a shuffled partition.");
    }
    a.out.table(sec, all_t, "every pilot, floor, budget and strategy, for further analysis.");
    if (!mom_t.rows.empty()) {
        mom_t.note =
            "Per pilot N0 where median-of-means is defined and per block count k (blocks of floor(N0 / k) "
            "contiguous samples, the remainder discarded), recomputed from each pilot draw's own samples; floor "
            "1, extra budget " +
            ex + ", mean over " + std::to_string(K) +
            " draws, unclamped PSNR. The "
            "pre-registered k is ceil(sqrt(N0)) (tab:robust-alloc; its MoM comes from the renderer's block "
            "moments, so its numbers can differ from this table's in the last digits). Both drop a block left "
            "with fewer than 2 finite samples.";
        rank_t.note =
            "Spearman rho between a pilot variance estimate and the pool's converged variance over the pixels of "
            "each reference bucket (at least 50 pixels), mean over the draws where it is defined (not constant). "
            "naive: the pilot's plain sample "
            "variance; MoM k: the median-of-means variance with k blocks (blank where blocks would hold fewer "
            "than 2 samples).";
        a.out.table(sec, mom_t,
                    "whether the robust incumbent's result depends on the block count, and whether the label's "
                    "floor helps at every k.");
        a.out.table(sec, rank_t,
                    "higher is better: how well each estimate orders the pixels of one bucket by their true "
                    "variance; the paper finds rare-tail buckets degrade as k grows while mid-tail ones improve.");
        a.out.figure(sec, fig_mom,
                     "per scene: PSNR against k for robust-var and robust-floor (solid N0 = 16, dashed N0 = 64).");
    }
    a.out.table(sec, timing_t, "what each strategy costs in seconds: the label costs nothing extra at render time.");
    a.out.figure(sec, fig_pilot,
                 "per scene: PSNR against the pilot budget (band: seed std over draws); oracle dashed.");
    a.out.figure(sec, fig_budget, "per scene: PSNR against the extra budget per pixel at the smallest pilot.");
    if (cfg.equal_time) {
        a.out.table(sec, eq_t,
                    "error against seconds: the comparison at equal wall-clock time rather than equal samples.");
        a.out.figure(sec, fig_time,
                     "per scene: PSNR against measured seconds for uniform, observed-var, bucket-floor, "
                     "guarded and shrink.");
        if (!eq_robust_t.rows.empty()) {
            eq_robust_t.note =
                "As tab:equal_time, at the first pilot where median-of-means is defined (the robust "
                "strategies are not defined at N0 = " +
                n0s +
                "); uniform and observed-var repeated "
                "at this pilot for reference.";
            a.out.table(sec, eq_robust_t,
                        "the same comparison at equal wall-clock time for robust-var, robust-floor "
                        "and robust-adaptive.");
            a.out.figure(sec, fig_time_robust,
                         "per scene: PSNR against measured seconds for uniform, observed-var, "
                         "robust-var, robust-floor and robust-adaptive.");
        }
    }
    a.out.check("bucket-floor beats observed-var on paired MSE in at least 7 of " + std::to_string(K) +
                    " draws at N0 = " + n0s + " on every scene with heavy-tailed buckets",
                fail_heavy.empty(),
                fail_heavy.empty() ? "on every such scene (tab:downstream)" : "not on: " + fail_heavy);
    a.out.check("the oracle (the pool's converged variance) beats uniform on PSNR at N0 = " + n0s + " on every scene",
                oracle_fail.empty(),
                (oracle_fail.empty() ? std::string("on every scene (tab:downstream)") : "not on: " + oracle_fail) +
                    "; the oracle's variance is measured on the same pool the final images average, as in the paper, "
                    "so it is partly in-sample");
    if (saw_cubes)
        a.out.check("bucket-floor equals observed-var exactly where no heavy-tailed bucket exists", cubes_tie,
                    "scenes without heavy-tailed pixels in the reference: " + tie_note);
}

}  // namespace vkmech
