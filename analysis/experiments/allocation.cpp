#include "experiments/allocation.hpp"
#include "experiments/allocation_data.hpp"

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
using namespace allocation_data;

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

double allocation_paths_per_pixel(const StudyConfig& cfg) {
    double per_pixel = cfg.alloc_ref_chunks * cfg.alloc_ref_chunk_spp +
                       static_cast<double>(downstream_seeds::kPoolSize) * cfg.alloc_pools;
    for (uint32_t n0 : cfg.alloc_pilots)
        per_pixel += cfg.alloc_draws * n0 + allocation_timed_strategies(n0).size() * (1.0 + cfg.alloc_extra);
    if (cfg.equal_time && !cfg.alloc_pilots.empty()) {
        std::vector<uint32_t> eq_pilots = {cfg.alloc_pilots.front()};  // the smallest pilot and the first robust one
        for (uint32_t n0 : cfg.alloc_pilots)
            if (alloc::mom_defined(static_cast<int>(n0))) {
                eq_pilots.push_back(n0);
                break;
            }
        for (uint32_t n0 : eq_pilots)
            for (uint32_t e : cfg.equal_time_budgets)
                per_pixel += allocation_equal_time_strategies(n0).size() * (1.0 + e);
    }
    return per_pixel;
}

namespace {

// ---- compute: per scene, every configuration's errors, the block-count sweep and the timings ----

const std::vector<Strategy> kBase = {Strategy::Uniform, Strategy::ObservedVar, Strategy::BucketFloor,
                                     Strategy::Oracle,  Strategy::Placebo,     Strategy::LabelOracle};
const std::vector<Strategy> kRobust = {Strategy::RobustVar, Strategy::RobustFloor, Strategy::RobustPlacebo,
                                       Strategy::RobustAdaptive};
// Not in the paper (§6.5, §6.6), with shrink's bucket-free placebo.
const std::vector<Strategy> kBeyond = {Strategy::Guarded, Strategy::Shrink, Strategy::ShrinkGlobal};

// The strategies of the main table's columns, in order.
const std::vector<Strategy> kMainColumns = {Strategy::Uniform, Strategy::ObservedVar, Strategy::BucketFloor,
                                            Strategy::Oracle,  Strategy::LabelOracle, Strategy::Placebo};

// The robust strategies need a pilot where median-of-means is defined: the first such N0 (0: none).
uint32_t first_robust_pilot(const StudyConfig& cfg) {
    for (uint32_t n0 : cfg.alloc_pilots)
        if (alloc::mom_defined(static_cast<int>(n0))) return n0;
    return 0;
}

using ErrorsByKey = std::map<Key, std::vector<Errors>>;

// The errors of one configuration over every draw, computed once.
const std::vector<Errors>& run_config(ErrorsByKey& res, const SceneData& d, uint32_t K, const Key& key) {
    auto it = res.find(key);
    if (it != res.end()) return it->second;
    std::vector<Errors>& errs = res[key];
    for (uint32_t k = 0; k < K; ++k) {
        AdaptivePlan plan = plan_allocation(key.s, pilot_inputs(d, key.n0, k), key.extra, key.floor,
                                            7919u * (k + 1));  // placebo: fresh per draw
        errs.push_back(evaluate(d, plan.n));
    }
    return errs;
}

// Every configuration of the tables at equal samples: every pilot and floor at the study's extra budget, and the
// budget sweep at every pilot (the figure draws the smallest's; downstream_all lists them all).
ErrorsByKey run_configs(const SceneData& d, const StudyConfig& cfg) {
    const uint32_t K = static_cast<uint32_t>(cfg.alloc_draws);
    ErrorsByKey res;
    for (uint32_t n0 : cfg.alloc_pilots)
        for (uint32_t floor : cfg.alloc_floors) {
            for (Strategy s : kBase) run_config(res, d, K, {n0, floor, cfg.alloc_extra, s});
            for (Strategy s : kBeyond) run_config(res, d, K, {n0, floor, cfg.alloc_extra, s});
            if (alloc::mom_defined(static_cast<int>(n0)))
                for (Strategy s : kRobust) run_config(res, d, K, {n0, floor, cfg.alloc_extra, s});
        }
    for (uint32_t n0 : cfg.alloc_pilots)
        for (uint32_t extra : cfg.alloc_budget_sweep)
            for (Strategy s : {Strategy::Uniform, Strategy::ObservedVar, Strategy::BucketFloor, Strategy::Oracle})
                run_config(res, d, K, {n0, 1, extra, s});
    return res;
}

// The median-of-means block-count sweep at one pilot N0 (paper §7 Result 3): for every block count k of the sweep,
// robust-var and robust-floor recomputed from the pilot's own samples, and the rank fidelity of each variance
// estimate against the pool's converged variance within each reference bucket.
struct MomSweep {
    uint32_t n0 = 0;
    std::vector<int> ks;
    std::map<int, std::vector<Errors>> ev, ef;                         // k -> per-draw errors (robust-var, -floor)
    std::map<int, std::array<std::vector<double>, kBucketCount>> rho;  // k -> bucket -> per-draw rho (k 0: naive)
    std::array<size_t, kBucketCount> members{};                        // pixels of each reference bucket
};

MomSweep mom_sweep(AllocationSource& source, const StudyConfig& cfg, const SceneVariant& scene, const SceneData& d,
                   uint32_t n0) {
    MomSweep m;
    m.n0 = n0;
    for (int k : cfg.alloc_mom_k)
        if (k >= 1 && static_cast<int>(n0) / k >= 2) m.ks.push_back(k);
    std::array<std::vector<size_t>, kBucketCount> members;
    for (size_t p = 0; p < d.P; ++p)
        if (d.ref_labels[p] != kNoLabel) members[d.ref_labels[p]].push_back(p);
    for (uint32_t b = 0; b < kBucketCount; ++b) m.members[b] = members[b].size();
    m.rho[0];  // the naive estimate's entry exists even where no bucket is large enough
    auto fidelity = [&](int k, const std::vector<double>& v) {
        for (uint32_t b = 0; b < kBucketCount; ++b) {
            if (members[b].size() < 50) continue;  // too few pixels for a rank correlation
            std::vector<double> x, y;
            for (size_t p : members[b]) {
                x.push_back(v[p]);
                y.push_back(d.pool.oracle_var[p]);
            }
            const double r = stats::spearman(x, y);  // NaN when one side is constant in this bucket
            if (std::isfinite(r)) m.rho[k][b].push_back(r);
        }
    };
    const uint32_t K = static_cast<uint32_t>(cfg.alloc_draws);
    for (uint32_t k = 0; k < K; ++k) {
        const Pilot& pl = d.pilots.at(n0)[k];
        const PilotSamples ps = source.pilot_samples(scene, n0, k);
        if (ps.pixels != d.P || ps.samples != n0)
            throw std::runtime_error("allocation study: the per-sample pilot " + std::to_string(k) + " of " +
                                     scene.name + " does not match its pilot");
        fidelity(0, pl.var);
        for (int kk : m.ks) {
            const std::vector<double> mv = ps.mom_variance(kk);
            fidelity(kk, mv);
            alloc::ScoreInputs in = pilot_inputs(d, n0, k);
            in.mom_var = &mv;
            m.ev[kk].push_back(evaluate(d, plan_allocation(Strategy::RobustVar, in, cfg.alloc_extra, 1, 0).n));
            m.ef[kk].push_back(evaluate(d, plan_allocation(Strategy::RobustFloor, in, cfg.alloc_extra, 1, 0).n));
        }
    }
    return m;
}

// Wall time of one strategy: the pilot's GPU time, the allocation, and a real GPU render of draw 0's n(p).
struct TimedRun {
    uint32_t n0 = 0;
    Strategy s = Strategy::Uniform;
    double pilot_s = 0, allocation_ms = 0, final_s = 0;
};

std::vector<TimedRun> time_strategies(AllocationSource& source, const StudyConfig& cfg, const SceneVariant& scene,
                                      const SceneData& d) {
    std::vector<TimedRun> runs;
    for (uint32_t n0 : cfg.alloc_pilots)
        for (Strategy s : allocation_timed_strategies(n0)) {
            AdaptivePlan plan = plan_allocation(s, pilot_inputs(d, n0, 0), cfg.alloc_extra, 1, 7919u);
            runs.push_back(
                {n0, s, d.pilots.at(n0)[0].seconds, plan.allocation_ms, source.final_render_seconds(scene, plan.n)});
        }
    return runs;
}

// Equal time at one pilot: per strategy and extra budget, the mean PSNR over the draws against the measured
// seconds of the mean pilot + draw 0's allocation + a real render of draw 0's n(p).
struct EqualTimePoint {
    uint32_t extra = 0;
    double seconds = 0, psnr = 0;
};
struct EqualTimeSeries {
    Strategy s = Strategy::Uniform;
    std::vector<EqualTimePoint> points;  // one per equal-time budget
};

std::vector<EqualTimeSeries> equal_time(AllocationSource& source, const StudyConfig& cfg, const SceneVariant& scene,
                                        const SceneData& d, const ErrorsByKey& res, uint32_t n0) {
    const uint32_t K = static_cast<uint32_t>(cfg.alloc_draws);
    ErrorsByKey more = res;  // the equal-time budgets beyond the tables' configurations
    double pilot_s = 0;
    for (const auto& pl : d.pilots.at(n0)) pilot_s += pl.seconds / K;
    std::vector<EqualTimeSeries> series;
    for (Strategy s : allocation_equal_time_strategies(n0)) {
        series.push_back({s, {}});
        for (uint32_t extra : cfg.equal_time_budgets) {
            const std::vector<Errors>& errs = run_config(more, d, K, {n0, 1, extra, s});
            AdaptivePlan plan = plan_allocation(s, pilot_inputs(d, n0, 0), extra, 1, 7919u);
            const double secs = pilot_s + plan.allocation_ms / 1000.0 + source.final_render_seconds(scene, plan.n);
            std::vector<double> ps;
            for (const auto& e : errs) ps.push_back(alloc::psnr(e.mse, d.peak));
            series.back().points.push_back({extra, secs, stats::mean(ps)});
        }
    }
    return series;
}

// What the writers need of one scene (the pool and the pilots stay behind).
struct AllocationScene {
    std::string name;
    double peak = 1.0;
    std::vector<uint8_t> ref_labels;
    std::vector<std::string> class_names;  // the labels' classes, `other` last
    bool heavy = false;                    // the reference has heavy-tailed pixels
    ErrorsByKey res;
    std::map<uint32_t, double> untrusted, rare;  // N0 -> the pilot's untrusted / rare-tail pixels, mean over draws
    std::vector<MomSweep> mom;
    std::vector<TimedRun> timed;
    std::vector<EqualTimeSeries> equal_main, equal_robust;
};

AllocationScene compute_scene(AllocationSource& source, const StudyConfig& cfg, const SceneVariant& scene,
                              const SceneData& d) {
    AllocationScene r;
    r.name = scene.name;
    r.peak = d.peak;
    r.ref_labels = d.ref_labels;
    r.class_names = d.class_names;
    for (uint8_t l : d.ref_labels) r.heavy |= alloc::is_heavy_tailed(l, d.traits.heavy);
    r.res = run_configs(d, cfg);
    for (uint32_t n0 : cfg.alloc_pilots) {
        double untrusted = 0.0, rare = 0.0;
        for (const alloc::PilotDiagnosis& dg : d.diagnoses.at(n0)) untrusted += static_cast<double>(dg.untrusted);
        r.untrusted[n0] = untrusted / static_cast<double>(d.diagnoses.at(n0).size());
        for (const Pilot& pl : d.pilots.at(n0))
            rare += static_cast<double>(alloc::rare_tail_pixels(pl.labels, d.traits.rare));
        r.rare[n0] = rare / static_cast<double>(d.pilots.at(n0).size());
    }
    for (uint32_t n0 : cfg.alloc_pilots)
        if (alloc::mom_defined(static_cast<int>(n0)) && !cfg.alloc_mom_k.empty())
            r.mom.push_back(mom_sweep(source, cfg, scene, d, n0));
    r.timed = time_strategies(source, cfg, scene, d);
    if (cfg.equal_time) {
        r.equal_main = equal_time(source, cfg, scene, d, r.res, cfg.alloc_pilots.front());
        if (const uint32_t n0_robust = first_robust_pilot(cfg); n0_robust != 0)
            r.equal_robust = equal_time(source, cfg, scene, d, r.res, n0_robust);
    }
    return r;
}

struct AllocationResult {
    uint32_t n0_main = 0, n0_robust = 0, K = 0;
    std::vector<AllocationScene> scenes;
};

// Every scene's tables at equal samples, and its pool resampling from the same loaded data (one scene in memory
// at a time: its pool is kPoolSize frames).
AllocationResult compute_allocation(const StudyConfig& cfg, AllocationSource& source, AllocationPools& pools) {
    AllocationResult r;
    r.n0_main = cfg.alloc_pilots.front();
    r.n0_robust = first_robust_pilot(cfg);
    r.K = static_cast<uint32_t>(cfg.alloc_draws);
    for (const auto& scene : cfg.scenes) {
        const SceneData d = load_scene_data(source, cfg, scene);
        r.scenes.push_back(compute_scene(source, cfg, scene, d));
        pools.add_scene(source, scene, d);
    }
    return r;
}

// ---- reading one scene's errors ----

std::string wins_text(const alloc::Paired& w) { return std::to_string(w.wins) + "/" + std::to_string(w.draws); }

struct SceneErrors {
    const AllocationScene& sc;
    std::vector<double> per_draw(const Key& k, double Errors::*field) const {
        std::vector<double> v;
        for (const auto& e : sc.res.at(k)) v.push_back(e.*field);
        return v;
    }
    std::vector<double> psnrs(const Key& k) const {  // unclamped linear RGB, peak = the reference's largest value
        std::vector<double> v;
        for (const auto& e : sc.res.at(k)) v.push_back(alloc::psnr(e.mse, sc.peak));
        return v;
    }
    std::vector<double> psnrs_clamped(const Key& k) const {  // RGB clamped to [0, 1], peak 1
        std::vector<double> v;
        for (const auto& e : sc.res.at(k)) v.push_back(alloc::psnr(e.mse_clamped));
        return v;
    }
    std::vector<double> mses(const Key& k, bool p99) const { return per_draw(k, p99 ? &Errors::p99 : &Errors::mse); }
    Cell psnr_cell(const Key& k) const { return Cell::num(stats::mean(psnrs(k)), "%.2f"); }
    // Paired MSE wins of configuration k over the same configuration with strategy `against`; "tie" when identical.
    Cell wins_cell(const Key& k, Strategy against) const {
        const auto ma = mses(k, false), mb = mses({k.n0, k.floor, k.extra, against}, false);
        if (ma == mb) return Cell::str("tie");
        return Cell::str(wins_text(alloc::paired_wins(ma, mb)));
    }
};

// ---- writers: the tables, figures and checks of the result ----

// The shape checks' findings, gathered from the main table's floor-1 rows.
struct MainChecks {
    std::string fail_heavy, tie_note, oracle_fail;
    bool cubes_tie = true, saw_cubes = false;
};

std::vector<Cell> main_row(const AllocationResult& r, const StudyConfig& cfg, const AllocationScene& sc, uint32_t floor,
                           MainChecks* checks) {
    const SceneErrors e{sc};
    std::vector<Cell> row{Cell::str(sc.name)};
    for (Strategy s : kMainColumns) row.push_back(e.psnr_cell({r.n0_main, floor, cfg.alloc_extra, s}));
    Key bf{r.n0_main, floor, cfg.alloc_extra, Strategy::BucketFloor},
        ov{r.n0_main, floor, cfg.alloc_extra, Strategy::ObservedVar};
    auto wm = alloc::paired_wins(e.mses(bf, false), e.mses(ov, false));
    auto wp = alloc::paired_wins(e.mses(bf, true), e.mses(ov, true));
    bool identical = e.mses(bf, false) == e.mses(ov, false);
    row.push_back(Cell::str(identical ? "tie" : wins_text(wm)));
    row.push_back(Cell::str(identical ? "tie" : wins_text(wp)));
    double lo = INFINITY, hi = 0;
    for (Strategy s : {Strategy::ObservedVar, Strategy::BucketFloor}) {  // uniform does not depend on the pilot
        double sd = std::sqrt(stats::sample_variance(e.psnrs({r.n0_main, floor, cfg.alloc_extra, s})));
        lo = std::min(lo, sd);
        hi = std::max(hi, sd);
    }
    row.push_back(Cell::str(report::format("%.2f", lo) + "-" + report::format("%.2f", hi)));
    if (checks) {
        if (sc.name == "cubes_dof") {
            checks->saw_cubes = true;
            checks->cubes_tie = identical;
        }
        if (sc.heavy && !identical && wm.wins < static_cast<int>((7 * r.K + 9) / 10))
            checks->fail_heavy += (checks->fail_heavy.empty() ? "" : ", ") + sc.name + " (" + std::to_string(wm.wins) +
                                  "/" + std::to_string(r.K) + ")";
        if (!sc.heavy)
            checks->tie_note += (checks->tie_note.empty() ? "" : ", ") + sc.name + (identical ? " (tie)" : " (no tie)");
    }
    return row;
}

// Beside the primary table: relative MSE (lower is better), the clamped display-range PSNR and the PSNR peak.
void add_beside_rows(const AllocationResult& r, const StudyConfig& cfg, const AllocationScene& sc, Table& rel_t,
                     Table& clamped_t, Table& peak_t, MainChecks& checks) {
    const SceneErrors e{sc};
    std::vector<Cell> rrow{Cell::str(sc.name)}, crow{Cell::str(sc.name)};
    for (Strategy s : kMainColumns) {
        Key k{r.n0_main, 1, cfg.alloc_extra, s};
        rrow.push_back(Cell::num(stats::mean(e.per_draw(k, &Errors::rel_mse)), "%.4g"));
        crow.push_back(Cell::num(stats::mean(e.psnrs_clamped(k)), "%.2f"));
    }
    Key bf{r.n0_main, 1, cfg.alloc_extra, Strategy::BucketFloor},
        ov{r.n0_main, 1, cfg.alloc_extra, Strategy::ObservedVar};
    auto wr = alloc::paired_wins(e.per_draw(bf, &Errors::rel_mse), e.per_draw(ov, &Errors::rel_mse));
    auto wc = alloc::paired_wins(e.per_draw(bf, &Errors::mse_clamped), e.per_draw(ov, &Errors::mse_clamped));
    const bool tie = e.per_draw(bf, &Errors::mse) == e.per_draw(ov, &Errors::mse);
    rrow.push_back(Cell::str(tie ? "tie" : wins_text(wr)));
    crow.push_back(Cell::str(tie ? "tie" : wins_text(wc)));
    rel_t.add(rrow);
    clamped_t.add(crow);
    const double pu = stats::mean(e.psnrs({r.n0_main, 1, cfg.alloc_extra, Strategy::Uniform}));
    const double po = stats::mean(e.psnrs({r.n0_main, 1, cfg.alloc_extra, Strategy::Oracle}));
    if (!(po > pu))
        checks.oracle_fail += (checks.oracle_fail.empty() ? "" : ", ") + sc.name + " (" + report::format("%.2f", po) +
                              " vs " + report::format("%.2f", pu) + " dB)";
    peak_t.add({Cell::str(sc.name), Cell::num(sc.peak, "%.4g")});
}

void add_robust_rows(const StudyConfig& cfg, const AllocationScene& sc, Table& robust_t) {
    const SceneErrors e{sc};
    for (uint32_t n0 : cfg.alloc_pilots) {
        if (!alloc::mom_defined(static_cast<int>(n0))) continue;
        auto m = [&](Strategy s) { return stats::mean(e.psnrs({n0, 1, cfg.alloc_extra, s})); };
        auto w = alloc::paired_wins(e.mses({n0, 1, cfg.alloc_extra, Strategy::RobustFloor}, false),
                                    e.mses({n0, 1, cfg.alloc_extra, Strategy::RobustVar}, false));
        robust_t.add({Cell::str(sc.name), Cell::integer(n0), Cell::num(m(Strategy::ObservedVar), "%.2f"),
                      Cell::num(m(Strategy::RobustVar), "%.2f"), Cell::num(m(Strategy::RobustFloor), "%.2f"),
                      Cell::num(m(Strategy::RobustPlacebo), "%.2f"), Cell::num(m(Strategy::BucketFloor), "%.2f"),
                      Cell::str(wins_text(w)), Cell::num(m(Strategy::Placebo) - m(Strategy::ObservedVar), "%+.2f"),
                      Cell::num(m(Strategy::BucketFloor) - m(Strategy::ObservedVar), "%+.2f"),
                      Cell::num(m(Strategy::RobustAdaptive), "%.2f"),
                      e.wins_cell({n0, 1, cfg.alloc_extra, Strategy::RobustAdaptive}, Strategy::RobustVar)});
    }
}

// The strategies beyond the paper (floor 1 and the f = 4 control) and the per-bucket adaptive block count.
void add_beyond_rows(const StudyConfig& cfg, const AllocationScene& sc, Table& beyond_t, Table& beyond_f4_t,
                     Table& adaptive_t) {
    const SceneErrors e{sc};
    for (uint32_t floor : cfg.alloc_floors)
        for (uint32_t n0 : cfg.alloc_pilots) {
            auto m = [&](Strategy s) { return e.psnr_cell({n0, floor, cfg.alloc_extra, s}); };
            auto wins = [&](Strategy s, Strategy against) {
                return e.wins_cell({n0, floor, cfg.alloc_extra, s}, against);
            };
            if (floor == 1 || floor == alloc::kStudyControlFloor)
                (floor == 1 ? beyond_t : beyond_f4_t)
                    .add({Cell::str(sc.name), Cell::integer(n0), Cell::num(sc.untrusted.at(n0), "%.1f"),
                          m(Strategy::Uniform), m(Strategy::ObservedVar), m(Strategy::BucketFloor),
                          m(Strategy::Guarded), m(Strategy::Shrink), m(Strategy::ShrinkGlobal), m(Strategy::Placebo),
                          wins(Strategy::Guarded, Strategy::BucketFloor), wins(Strategy::Shrink, Strategy::ObservedVar),
                          wins(Strategy::Shrink, Strategy::ShrinkGlobal)});
            if (!alloc::mom_defined(static_cast<int>(n0))) continue;
            adaptive_t.add({Cell::str(sc.name), Cell::integer(n0), Cell::integer(floor),
                            Cell::num(sc.rare.at(n0), "%.1f"), m(Strategy::Uniform), m(Strategy::ObservedVar),
                            m(Strategy::BucketFloor), m(Strategy::RobustVar), m(Strategy::RobustFloor),
                            m(Strategy::Placebo), m(Strategy::RobustPlacebo), m(Strategy::RobustAdaptive),
                            wins(Strategy::RobustAdaptive, Strategy::RobustVar),
                            wins(Strategy::RobustAdaptive, Strategy::ObservedVar),
                            wins(Strategy::RobustAdaptive, Strategy::RobustFloor)});
        }
}

void add_all_rows(const AllocationScene& sc, Table& all_t) {
    const SceneErrors e{sc};
    for (const auto& [k, errs] : sc.res) {
        auto p = e.psnrs(k);
        auto w = alloc::paired_wins(e.mses(k, false), e.mses({k.n0, k.floor, k.extra, Strategy::ObservedVar}, false));
        bool has_ov = sc.res.count({k.n0, k.floor, k.extra, Strategy::ObservedVar}) > 0;
        all_t.add({Cell::str(sc.name), Cell::integer(k.n0), Cell::integer(k.floor), Cell::integer(k.extra),
                   Cell::str(alloc::to_string(k.s)), Cell::num(stats::mean(p), "%.3f"),
                   Cell::num(std::sqrt(stats::sample_variance(p)), "%.3f"),
                   Cell::num(stats::mean(e.mses(k, false)), "%.4g"),
                   Cell::num(std::sqrt(stats::sample_variance(e.mses(k, false))), "%.4g"),
                   Cell::num(stats::mean(e.per_draw(k, &Errors::rel_mse)), "%.4g"),
                   Cell::num(stats::mean(e.mses(k, true)), "%.4g"), Cell::num(stats::mean(e.psnrs_clamped(k)), "%.3f"),
                   Cell::str(has_ov ? wins_text(w) : "")});
    }
}

void add_bucket_rows(const AllocationResult& r, const StudyConfig& cfg, const AllocationScene& sc, Table& bucket_t) {
    for (uint32_t b = 0; b + 1 < sc.class_names.size(); ++b) {  // every class but `other`
        size_t n = 0;
        for (uint8_t l : sc.ref_labels) n += l == b;
        if (n == 0) continue;
        auto bm = [&](Strategy s) {
            std::vector<double> v;
            for (const auto& e : sc.res.at({r.n0_main, 1, cfg.alloc_extra, s})) v.push_back(e.bucket_mse[b]);
            return stats::mean(v);
        };
        double o = bm(Strategy::ObservedVar), f = bm(Strategy::BucketFloor);
        bucket_t.add({Cell::str(sc.name), Cell::str(sc.class_names[b]), Cell::integer(static_cast<long long>(n)),
                      Cell::num(o, "%.4g"), Cell::num(f, "%.4g"), Cell::num(f / o, "%.3f")});
    }
}

// Figures: PSNR vs pilot budget, PSNR vs extra budget (band: seed std over draws).
void add_budget_panels(const AllocationResult& r, const StudyConfig& cfg, const AllocationScene& sc,
                       report::Figure& fig_pilot, report::Figure& fig_budget) {
    const SceneErrors e{sc};
    report::Panel pp, pb;
    pp.title = pb.title = sc.name;
    pp.xlabel = "pilot N0 (SPP)";
    pb.xlabel = "extra SPP per pixel";
    pp.ylabel = pb.ylabel = "PSNR (dB)";
    pp.logx = pb.logx = true;
    auto point = [](report::Series& sr, double x, const std::vector<double>& p) {
        double mu = stats::mean(p), sd = std::sqrt(stats::sample_variance(p));
        sr.x.push_back(x);
        sr.y.push_back(mu);
        sr.lo.push_back(mu - sd);
        sr.hi.push_back(mu + sd);
    };
    for (Strategy s : {Strategy::Uniform, Strategy::ObservedVar, Strategy::Oracle, Strategy::BucketFloor}) {
        const std::string& col = kStrategyColors.at(s);
        report::Series sp{alloc::to_string(s), {}, {}, {}, {}, col, "o", s == Strategy::Oracle ? "--" : "-", 0, 0, {}};
        report::Series sb = sp;
        for (uint32_t n0 : cfg.alloc_pilots) point(sp, n0, e.psnrs({n0, 1, cfg.alloc_extra, s}));
        for (uint32_t extra : cfg.alloc_budget_sweep) point(sb, extra, e.psnrs({r.n0_main, 1, extra, s}));
        pp.series.push_back(sp);
        pb.series.push_back(sb);
    }
    fig_pilot.panels.push_back(pp);
    fig_budget.panels.push_back(pb);
}

// The block-count sweep's rows (tab:mom_sweep, tab:mom_rank_fidelity) and its figure panel.
void add_mom_rows(const StudyConfig& cfg, const AllocationScene& sc, Table& mom_t, Table& rank_t,
                  report::Figure& fig_mom) {
    report::Panel pm;
    pm.title = sc.name;
    pm.xlabel = "median-of-means block count k";
    pm.ylabel = "PSNR (dB)";
    for (const MomSweep& m : sc.mom) {
        const uint32_t n0 = m.n0;
        const char* style = n0 == 16 ? "-" : "--";
        report::Series sv{"robust-var N0=" + std::to_string(n0), {}, {}, {}, {}, "#D55E00", "o", style, 0, 0, {}};
        report::Series sf{"robust-floor N0=" + std::to_string(n0), {}, {}, {}, {}, "#0072B2", "o", style, 0, 0, {}};
        for (int kk : m.ks) {
            std::vector<double> pv, pf, mv, mf;
            for (const Errors& e : m.ev.at(kk)) {
                pv.push_back(alloc::psnr(e.mse, sc.peak));
                mv.push_back(e.mse);
            }
            for (const Errors& e : m.ef.at(kk)) {
                pf.push_back(alloc::psnr(e.mse, sc.peak));
                mf.push_back(e.mse);
            }
            mom_t.add({Cell::str(sc.name), Cell::integer(n0), Cell::integer(kk),
                       Cell::integer(alloc::mom_block_size(static_cast<int>(n0), kk)),
                       Cell::num(stats::mean(pv), "%.2f"), Cell::num(stats::mean(pf), "%.2f"),
                       Cell::num(stats::mean(pf) - stats::mean(pv), "%+.2f"),
                       Cell::str(wins_text(alloc::paired_wins(mf, mv)))});
            sv.x.push_back(kk);
            sv.y.push_back(stats::mean(pv));
            sf.x.push_back(kk);
            sf.y.push_back(stats::mean(pf));
        }
        pm.series.push_back(sv);
        pm.series.push_back(sf);
        for (uint32_t b = 0; b < sc.class_names.size(); ++b) {
            if (m.rho.at(0)[b].empty()) continue;
            std::vector<Cell> row{Cell::str(sc.name), Cell::integer(n0), Cell::str(sc.class_names[b]),
                                  Cell::integer(static_cast<long long>(m.members[b])),
                                  Cell::num(stats::mean(m.rho.at(0)[b]), "%.3f")};
            for (int kk : cfg.alloc_mom_k)
                row.push_back(m.rho.count(kk) && !m.rho.at(kk)[b].empty()
                                  ? Cell::num(stats::mean(m.rho.at(kk)[b]), "%.3f")
                                  : Cell::str(""));
            rank_t.add(row);
        }
    }
    if (!pm.series.empty()) fig_mom.panels.push_back(pm);
}

void add_timing_rows(const StudyConfig& cfg, const AllocationScene& sc, Table& timing_t) {
    const SceneErrors e{sc};
    for (const TimedRun& t : sc.timed)
        timing_t.add({Cell::str(sc.name), Cell::integer(t.n0), Cell::str(alloc::to_string(t.s)),
                      Cell::num(t.pilot_s, "%.3f"), Cell::num(t.allocation_ms, "%.2f"), Cell::num(t.final_s, "%.3f"),
                      Cell::num(t.pilot_s + t.allocation_ms / 1000.0 + t.final_s, "%.3f"),
                      Cell::num(stats::mean(e.psnrs({t.n0, 1, cfg.alloc_extra, t.s})), "%.2f")});
}

// One scene's equal-time rows and its figure panel (one series per strategy).
void add_equal_time_rows(const AllocationScene& sc, const std::vector<EqualTimeSeries>& series, Table& t,
                         report::Figure& fig) {
    report::Panel pt;
    pt.title = sc.name;
    pt.xlabel = "wall-clock seconds (pilot + allocation + final render)";
    pt.ylabel = "PSNR (dB)";
    pt.logx = true;
    for (const EqualTimeSeries& es : series) {
        report::Series st{alloc::to_string(es.s), {}, {}, {}, {}, kStrategyColors.at(es.s), "o", "-", 0, 0, {}};
        for (const EqualTimePoint& q : es.points) {
            t.add({Cell::str(sc.name), Cell::str(alloc::to_string(es.s)), Cell::integer(q.extra),
                   Cell::num(q.seconds, "%.3f"), Cell::num(q.psnr, "%.2f")});
            st.x.push_back(q.seconds);
            st.y.push_back(q.psnr);
        }
        pt.series.push_back(st);
    }
    fig.panels.push_back(pt);
}

// The study's tables and figures, empty, in the order of their columns.
struct AllocationTables {
    Table main_t, f4_t, robust_t, rel_t, clamped_t, peak_t, all_t, bucket_t;
    Table beyond_t, beyond_f4_t, adaptive_t, timing_t, eq_t, eq_robust_t, mom_t, rank_t;
    report::Figure fig_pilot, fig_budget, fig_mom, fig_time, fig_time_robust;
};

// The tables at equal samples: the main one, its f = 4 control and the views beside it.
void make_equal_sample_tables(const AllocationResult& r, AllocationTables& t) {
    const std::string n0s = std::to_string(r.n0_main);
    t.main_t = {"downstream",
                "",
                {"scene", "uniform", "obs-var", "b-floor", "oracle", "label-oracle", "placebo", "MSE wins", "p99 wins",
                 "seed std obs/b-floor (dB)"},
                {},
                ""};
    t.f4_t = t.main_t;
    t.robust_t = {"robust_alloc",
                  "Robust-variance incumbent at the pilots where median-of-means is defined (tab:robust-alloc)",
                  {"scene", "N0", "obs-var", "robust-var", "robust-floor", "robust-placebo", "b-floor",
                   "MSE wins r-floor vs r-var", "placebo dB vs obs-var", "b-floor dB vs obs-var", "robust-adaptive",
                   "MSE wins r-adaptive vs r-var"},
                  {},
                  ""};
    t.rel_t = {"downstream_relmse",
               "Relative MSE at pilot N0 = " + n0s + ", floor 1 (unclamped linear RGB)",
               {"scene", "uniform", "obs-var", "b-floor", "oracle", "label-oracle", "placebo", "relMSE wins"},
               {},
               ""};
    t.clamped_t = {"downstream_clamped",
                   "Clamped display-range PSNR at pilot N0 = " + n0s +
                       ", floor 1 (RGB clamped to [0, 1]; beside tab:downstream, not instead)",
                   {"scene", "uniform", "obs-var", "b-floor", "oracle", "label-oracle", "placebo", "clamped MSE wins"},
                   {},
                   ""};
    t.peak_t = {"downstream_peak",
                "The PSNR peak of each scene: the reference's largest linear RGB value",
                {"scene", "peak"},
                {},
                ""};
    t.all_t = {"downstream_all",
               "Every configuration: PSNR (dB, unclamped, reference peak) mean and seed std, MSE mean and seed "
               "std, relative MSE and p99 error on unclamped linear RGB, the clamped PSNR beside them, paired wins "
               "against observed-var",
               {"scene", "N0", "floor", "extra SPP", "strategy", "PSNR", "PSNR std", "MSE", "MSE std", "rel MSE",
                "p99 |lum err|", "PSNR clamped", "MSE wins vs obs-var"},
               {},
               ""};
    t.bucket_t = {"perbucket_mse",
                  "Per-bucket MSE (unclamped linear RGB) at N0 = " + n0s + " (buckets of the reference)",
                  {"scene", "bucket", "pixels", "obs-var", "b-floor", "b-floor / obs-var"},
                  {},
                  ""};
}

// The tables beyond equal samples: strategies past the paper, the block-count sweep, wall time, and the figures.
void make_other_tables(const StudyConfig& cfg, const std::string& device, const AllocationResult& r,
                       AllocationTables& t) {
    t.beyond_t = {
        "beyond_floor",
        "Strategies beyond the paper: guarded (§6.5) and shrink (§6.6), floor 1",
        {"scene", "N0", "untrusted px", "uniform", "obs-var", "b-floor", "guarded", "shrink", "shrink-global",
         "placebo", "MSE wins guarded vs b-floor", "MSE wins shrink vs obs-var", "MSE wins shrink vs shrink-global"},
        {},
        ""};
    t.beyond_f4_t = t.beyond_t;
    t.beyond_f4_t.name = "beyond_floor_f4";
    t.beyond_f4_t.title =
        "Strategies beyond the paper: guarded (§6.5) and shrink (§6.6), the f = 4 sample-floor control";
    t.adaptive_t = {"robust_adaptive",
                    "The per-bucket adaptive median-of-means block count (robust-adaptive, §6.7) "
                    "against the other strategies at equal samples",
                    {"scene", "N0", "floor", "rare-tail px", "uniform", "obs-var", "b-floor", "robust-var",
                     "robust-floor", "placebo", "robust-placebo", "robust-adaptive", "MSE wins r-adaptive vs r-var",
                     "MSE wins r-adaptive vs obs-var", "MSE wins r-adaptive vs r-floor"},
                    {},
                    ""};
    t.timing_t = {"alloc_time",
                  "Wall time of each strategy on " + device + ": pilot + allocation + final render",
                  {"scene", "N0", "strategy", "pilot s", "allocation ms", "final s", "total s", "PSNR"},
                  {},
                  ""};
    t.eq_t = {"equal_time",
              "Error versus wall-clock time (N0 = " + std::to_string(r.n0_main) + ", floor 1)",
              {"scene", "strategy", "extra SPP", "seconds", "PSNR"},
              {},
              ""};
    t.eq_robust_t = {"equal_time_robust",
                     "Error versus wall-clock time of the median-of-means strategies (N0 = " +
                         std::to_string(r.n0_robust) + ", floor 1)",
                     t.eq_t.columns,
                     {},
                     ""};
    t.mom_t = {"mom_sweep",
               "Median-of-means block-count sweep: robust-var and robust-floor PSNR against the block count k",
               {"scene", "N0", "k", "block size", "robust-var", "robust-floor", "floor - var (dB)",
                "MSE wins r-floor vs r-var"},
               {},
               ""};
    t.rank_t = {"mom_rank_fidelity",
                "Within-bucket rank fidelity of the pilot variance against the pool's converged variance",
                {"scene", "N0", "bucket", "pixels", "naive"},
                {},
                ""};
    for (int k : cfg.alloc_mom_k) t.rank_t.columns.push_back("MoM k=" + std::to_string(k));
    t.fig_pilot = {"psnr_vs_pilot", "Equal-budget PSNR versus pilot budget (mean and seed std over draws)", "", 0, {}};
    t.fig_budget = {"psnr_vs_budget", "PSNR versus extra budget at N0 = " + std::to_string(r.n0_main), "", 0, {}};
    t.fig_mom = {"psnr_vs_mom_k", "PSNR versus the median-of-means block count k", "", 0, {}};
    t.fig_time = {"error_vs_time", "PSNR versus wall-clock seconds (pilot + allocation + final render)", "", 0, {}};
    t.fig_time_robust = {
        "error_vs_time_robust",
        "PSNR versus wall-clock seconds of the median-of-means strategies at N0 = " + std::to_string(r.n0_robust),
        "",
        0,
        {}};
}

// Every table's rows, scene by scene; returns the shape checks' findings.
MainChecks fill_tables(const StudyConfig& cfg, const AllocationResult& r, AllocationTables& t) {
    MainChecks checks;
    const bool has_f4 = std::find(cfg.alloc_floors.begin(), cfg.alloc_floors.end(), 4u) != cfg.alloc_floors.end();
    for (const AllocationScene& sc : r.scenes) {
        t.main_t.add(main_row(r, cfg, sc, 1, &checks));
        add_beside_rows(r, cfg, sc, t.rel_t, t.clamped_t, t.peak_t, checks);
        if (has_f4) t.f4_t.add(main_row(r, cfg, sc, 4, nullptr));
        add_robust_rows(cfg, sc, t.robust_t);
        add_beyond_rows(cfg, sc, t.beyond_t, t.beyond_f4_t, t.adaptive_t);
        add_all_rows(sc, t.all_t);
        add_bucket_rows(r, cfg, sc, t.bucket_t);
        add_budget_panels(r, cfg, sc, t.fig_pilot, t.fig_budget);
        add_mom_rows(cfg, sc, t.mom_t, t.rank_t, t.fig_mom);
        add_timing_rows(cfg, sc, t.timing_t);
        if (cfg.equal_time) {
            add_equal_time_rows(sc, sc.equal_main, t.eq_t, t.fig_time);
            if (r.n0_robust != 0) add_equal_time_rows(sc, sc.equal_robust, t.eq_robust_t, t.fig_time_robust);
        }
    }
    return checks;
}

// The notes of the tables at equal samples.
void note_equal_sample_tables(const StudyConfig& cfg, const AllocationResult& r, AllocationTables& t) {
    const std::string n0s = std::to_string(r.n0_main), ex = std::to_string(cfg.alloc_extra);
    t.main_t.title = "Equal-budget allocation at pilot N0 = " + n0s + ", floor 1 (tab:downstream)";
    t.main_t.note =
        "PSNR (dB) on unclamped linear RGB, 10 log10(peak^2 / MSE) with the reference's largest RGB value as "
        "the peak (tables/downstream_peak.md), against an independent " +
        std::to_string(cfg.alloc_ref_chunks * cfg.alloc_ref_chunk_spp) + "-SPP reference, mean over " +
        std::to_string(r.K) +
        " disjoint pilot draws (the mean of the per-draw PSNRs, i.e. the PSNR of the geometric-mean "
        "MSE; a bad draw weighs less in dB than in MSE); every strategy spends exactly (1 + " +
        ex +
        ") x pixels samples of the shared 256-frame pool. MSE / p99 wins: draws in which bucket-floor has a "
        "lower MSE / 99th-percentile luminance error than observed-var; \"tie\": identical in every draw. The "
        "clamped display-range PSNR is in tab:downstream-clamped, beside this one.";
    t.rel_t.note =
        "Mean over the draws of the relative MSE (x - r)^2 / (r^2 + 0.01) per pixel and channel, unclamped; "
        "relMSE wins: draws in which bucket-floor's relative MSE is below observed-var's. The 0.01 keeps "
        "black pixels finite: where r is well below 0.1 the figure is close to 100 x the absolute squared "
        "error, so in a dim scene this table ranks much as the MSE does.";
    t.clamped_t.note =
        "RGB clamped to [0, 1] (exposure 1) on both sides, peak 1. Clamping caps exactly the heavy-tailed "
        "errors the strategies exist to repair (a caustic or firefly pixel far above 1 counts as 1), so "
        "these figures are reported beside the unclamped ones, never instead.";
    t.f4_t.name = "downstream_f4";
    t.f4_t.title = "The f = 4 sample-floor control at N0 = " + n0s + " (tab:downstream-f4)";
    t.f4_t.note =
        "As tab:downstream with every pixel guaranteed 4 samples, deducted from the Neyman share (totals unchanged).";
    t.robust_t.note =
        "Median-of-means over k = ceil(sqrt(N0)) contiguous blocks of the pilot (per-block ddof 1, remainder "
        "discarded); not defined at N0 = 4. Placebo / b-floor columns: PSNR gain over observed-var of the "
        "shuffled-label floor and of the real one — the gain specific to the label is the difference. robust-adaptive "
        "(§6.7): k chosen per pilot label, its wins against robust-var (\"tie\": identical in every draw).";
    t.timing_t.note =
        "Measured on this device for pilot draw 0 (GPU times vary run to run; the error columns do not). The "
        "final render is the GPU adaptive render of the strategy's n(p).";
    t.eq_t.note =
        "Each point: the mean PSNR over the draws at one extra budget, against the measured wall time of pilot + "
        "allocation + final render.";
}

void write_equal_sample_tables(StudyOutput& out, const std::string& sec, const AllocationTables& t) {
    out.table(sec, t.main_t,
              "higher is better; the paper's claim is that bucket-floor beats observed-var in most draws "
              "wherever heavy-tailed buckets exist, and ties it exactly where they do not (cubes_dof).");
    if (!t.f4_t.rows.empty())
        out.table(sec, t.f4_t,
                  "the same with a shared floor of 4 samples: what a plain sample floor repairs on its own.");
    if (!t.robust_t.rows.empty())
        out.table(sec, t.robust_t,
                  "whether a robust variance estimator already does what the label does; the placebo "
                  "column is the gain any partition would give.");
    out.table(sec, t.rel_t,
              "lower is better: the error relative to the reference's own brightness (for pixels brighter "
              "than about 0.1), so bright caustics do not dominate it as they dominate the MSE.");
    out.table(sec, t.clamped_t,
              "the display-range view of the same images: where it disagrees with tab:downstream, the "
              "difference sits in pixels brighter than 1.");
    out.table(sec, t.peak_t, "the peak each scene's PSNR is taken against.");
    out.table(sec, t.bucket_t, "where bucket-floor's gain or loss lands, by the reference's dominant bucket.");
}

void write_beyond_tables(StudyOutput& out, const std::string& sec, const StudyConfig& cfg, AllocationTables& t) {
    const std::string ex = std::to_string(cfg.alloc_extra);
    t.beyond_t.note =
        "PSNR (dB, unclamped, reference peak), mean over the draws, at every pilot N0, floor 1, extra budget " + ex +
        ". untrusted px: the pilot's untrusted pixels (§6.5), mean over the draws. guarded: bucket-floor "
        "with at least the uniform share on them; shrink: the pilot variance shrunk on the log scale towards "
        "its label's empirical-Bayes prior; shrink-global: its placebo, the same shrinkage towards one prior over "
        "every labelled pixel (no label), so shrink's gain beyond it is the label's. Wins: draws with the lower MSE; "
        "\"tie\": identical in every draw.";
    out.table(sec, t.beyond_t,
              "whether the two strategies that go past the paper help: guarded should matter only where "
              "the pilot leaves untrusted pixels, shrink most at the shortest pilot.");
    if (!t.beyond_f4_t.rows.empty()) {
        t.beyond_f4_t.note = "As tab:beyond_floor with every pixel guaranteed " +
                             std::to_string(alloc::kStudyControlFloor) +
                             " samples, deducted from the Neyman share (totals unchanged).";
        out.table(sec, t.beyond_f4_t,
                  "the same with a shared floor of 4 samples: whether guarded and shrink still help "
                  "once a plain sample floor protects every pixel.");
    }
    if (!t.adaptive_t.rows.empty()) {
        t.adaptive_t.note = "PSNR (dB, unclamped, reference peak), mean over the draws, extra budget " + ex +
                            ", at every pilot where median-of-means is defined and every floor. robust-adaptive: the "
                            "plain pilot variance (k = 1) on pixels whose pilot label is " +
                            (cfg.taxonomy ? std::string("a class the taxonomy declares [rare]")
                                          : std::string("delta_mediated or specular_direct")) +
                            ", robust-var's median-of-means (k = ceil(sqrt(N0))) everywhere else, "
                            "unlabelled pixels included (§6.7); the rule was fixed a priori, not fitted to these "
                            "scenes. rare-tail px: the pilot's pixels where k = 1, mean over the draws (0: "
                            "robust-adaptive is robust-var bit for bit). Wins: draws with the lower MSE; \"tie\": "
                            "identical in every draw.";
        out.table(sec, t.adaptive_t,
                  "whether choosing the block count per pilot label beats one block count for every "
                  "pixel (robust-var), the label's floor (robust-floor) and the plain variance; the "
                  "placebo columns are the gain of a shuffled partition.");
    }
    out.table(sec, t.all_t, "every pilot, floor, budget and strategy, for further analysis.");
}

void write_mom_tables(StudyOutput& out, const std::string& sec, const StudyConfig& cfg, const AllocationResult& r,
                      AllocationTables& t) {
    if (t.mom_t.rows.empty()) return;
    t.mom_t.note =
        "Per pilot N0 where median-of-means is defined and per block count k (blocks of floor(N0 / k) "
        "contiguous samples, the remainder discarded), recomputed from each pilot draw's own samples; floor "
        "1, extra budget " +
        std::to_string(cfg.alloc_extra) + ", mean over " + std::to_string(r.K) +
        " draws, unclamped PSNR. The "
        "pre-registered k is ceil(sqrt(N0)) (tab:robust-alloc; its MoM comes from the renderer's block "
        "moments, so its numbers can differ from this table's in the last digits). Both drop a block left "
        "with fewer than 2 finite samples.";
    t.rank_t.note =
        "Spearman rho between a pilot variance estimate and the pool's converged variance over the pixels of "
        "each reference bucket (at least 50 pixels), mean over the draws where it is defined (not constant). "
        "naive: the pilot's plain sample "
        "variance; MoM k: the median-of-means variance with k blocks (blank where blocks would hold fewer "
        "than 2 samples).";
    out.table(sec, t.mom_t,
              "whether the robust incumbent's result depends on the block count, and whether the label's "
              "floor helps at every k.");
    out.table(sec, t.rank_t,
              "higher is better: how well each estimate orders the pixels of one bucket by their true "
              "variance; the paper finds rare-tail buckets degrade as k grows while mid-tail ones improve.");
    out.figure(sec, t.fig_mom,
               "per scene: PSNR against k for robust-var and robust-floor (solid N0 = 16, dashed N0 = 64).");
}

void write_time_tables(StudyOutput& out, const std::string& sec, const StudyConfig& cfg, const AllocationResult& r,
                       AllocationTables& t) {
    out.table(sec, t.timing_t, "what each strategy costs in seconds: the label costs nothing extra at render time.");
    out.figure(sec, t.fig_pilot,
               "per scene: PSNR against the pilot budget (band: seed std over draws); oracle dashed.");
    out.figure(sec, t.fig_budget, "per scene: PSNR against the extra budget per pixel at the smallest pilot.");
    if (!cfg.equal_time) return;
    out.table(sec, t.eq_t, "error against seconds: the comparison at equal wall-clock time rather than equal samples.");
    out.figure(sec, t.fig_time,
               "per scene: PSNR against measured seconds for uniform, observed-var, bucket-floor, "
               "guarded and shrink.");
    if (t.eq_robust_t.rows.empty()) return;
    t.eq_robust_t.note =
        "As tab:equal_time, at the first pilot where median-of-means is defined (the robust "
        "strategies are not defined at N0 = " +
        std::to_string(r.n0_main) +
        "); uniform and observed-var repeated "
        "at this pilot for reference.";
    out.table(sec, t.eq_robust_t,
              "the same comparison at equal wall-clock time for robust-var, robust-floor "
              "and robust-adaptive.");
    out.figure(sec, t.fig_time_robust,
               "per scene: PSNR against measured seconds for uniform, observed-var, "
               "robust-var, robust-floor and robust-adaptive.");
}

void write_checks(StudyOutput& out, const AllocationResult& r, const MainChecks& c) {
    const std::string n0s = std::to_string(r.n0_main);
    out.check("bucket-floor beats observed-var on paired MSE in at least 7 of " + std::to_string(r.K) +
                  " draws at N0 = " + n0s + " on every scene with heavy-tailed buckets",
              c.fail_heavy.empty(),
              c.fail_heavy.empty() ? "on every such scene (tab:downstream)" : "not on: " + c.fail_heavy);
    out.check("the oracle (the pool's converged variance) beats uniform on PSNR at N0 = " + n0s + " on every scene",
              c.oracle_fail.empty(),
              (c.oracle_fail.empty() ? std::string("on every scene (tab:downstream)") : "not on: " + c.oracle_fail) +
                  "; the oracle's variance is measured on the same pool the final images average, as in the paper, "
                  "so it is partly in-sample");
    if (c.saw_cubes)
        out.check("bucket-floor equals observed-var exactly where no heavy-tailed bucket exists", c.cubes_tie,
                  "scenes without heavy-tailed pixels in the reference: " + c.tie_note);
}

void write_allocation(StudyOutput& out, const StudyConfig& cfg, const std::string& device, const AllocationResult& r) {
    const std::string sec = "Downstream allocation";
    AllocationTables t;
    make_equal_sample_tables(r, t);
    make_other_tables(cfg, device, r, t);
    const MainChecks checks = fill_tables(cfg, r, t);
    note_equal_sample_tables(cfg, r, t);
    if (cfg.taxonomy)
        out.text(sec, taxonomy_labels_lead(cfg) +
                          ", not the paper's buckets. Wherever a table or a note below says bucket, "
                          "read class; the heavy-tailed classes are the lines declared `[heavy]`, the rare-tail "
                          "ones `[rare]`, and those whose zero pilot variance the guard trusts `[constant]`.");
    write_equal_sample_tables(out, sec, t);
    write_beyond_tables(out, sec, cfg, t);
    write_mom_tables(out, sec, cfg, r, t);
    write_time_tables(out, sec, cfg, r, t);
    write_checks(out, r, checks);
}

}  // namespace

void run_allocation(StudyContext& ctx) {
    if (!ctx.allocation) throw std::logic_error("allocation study: no allocation source in the study context");
    AllocationPools pools(ctx.cfg);
    write_allocation(ctx.out, ctx.cfg, ctx.device, compute_allocation(ctx.cfg, *ctx.allocation, pools));
    pools.write(ctx.out);
}

}  // namespace vkmech
