#include "experiments/sentinel_eval.hpp"

#include "allocation/allocation.hpp"
#include "io/invariant.hpp"
#include "io/json.hpp"
#include "render/descriptor.hpp"
#include "shared/types.h"
#include "stats/agreement.hpp"
#include "stats/bootstrap.hpp"
#include "stats/rank.hpp"
#include "stats/summary.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

namespace vkmech::sentinel {

namespace {

using alloc::Strategy;

std::string fmt(const char* f, double x) {
    if (!std::isfinite(x)) return "n/a";
    char b[64];
    std::snprintf(b, sizeof b, f, x);
    return b;
}

struct Scores {
    std::map<std::string, StrategyScore> by_name;
    std::map<std::string, std::vector<std::vector<uint32_t>>> plans;  // per draw
};

std::string verdict_band(double predicted, double measured, double tol) {
    if (!std::isfinite(measured) || !std::isfinite(predicted) || !std::isfinite(tol)) return "INDETERMINATE";
    return std::abs(measured - predicted) <= tol ? "PASS" : "FAIL";
}

void check_inputs(const Record& r, const EvalInputs& in) {
    VKM_ASSERT(in.reference && in.pool, "sentinel evaluate: no reference or pool");
    const Frame& ref = *in.reference;
    const size_t P = static_cast<size_t>(ref.width) * ref.height;
    if (ref.width != r.width || ref.height != r.height)
        throw std::invalid_argument("sentinel evaluate: the reference is " + std::to_string(ref.width) + "x" +
                                    std::to_string(ref.height) + ", the record's film " + std::to_string(r.width) +
                                    "x" + std::to_string(r.height));
    if (in.pool->pixels != P || in.pool->frames < r.protocol.extra_spp + 1)
        throw std::invalid_argument("sentinel evaluate: the pool does not match the film or the budget");
    if (in.pilots.empty() || in.pilots.size() != r.protocol.draws)
        throw std::invalid_argument("sentinel evaluate: " + std::to_string(in.pilots.size()) +
                                    " pilot draws, the protocol has " + std::to_string(r.protocol.draws));
    for (const Pilot& p : in.pilots)
        if (p.var.size() != P) throw std::invalid_argument("sentinel evaluate: a pilot does not match the film");
}

// Reproducibility: the registered pilot, rendered again, must give the registered diagnosis.
void check_reproduced(const Record& r, const alloc::PilotDiagnosis& d0, Evaluation& e) {
    const alloc::PilotDiagnosis& rdg = r.diagnosis;
    e.pilot_reproduced = d0.pixels == rdg.pixels && d0.labelled == rdg.labelled && d0.seen == rdg.seen &&
                         d0.heavy == rdg.heavy && d0.floor_changed == rdg.floor_changed &&
                         d0.untrusted == rdg.untrusted && d0.robust_floor_changed == rdg.robust_floor_changed;
    e.checks.push_back(
        e.pilot_reproduced
            ? "the registered pilot (seed " + std::to_string(r.pilot_seed) +
                  "), rendered again, gives the registered diagnosis (labelled, seen, heavy, floor "
                  "changes, untrusted pixels): the predictions were made from this pilot"
            : "the registered pilot, rendered again, does NOT give the registered diagnosis (labelled " +
                  std::to_string(d0.labelled) + " vs " + std::to_string(rdg.labelled) + ", untrusted " +
                  std::to_string(d0.untrusted) + " vs " + std::to_string(rdg.untrusted) +
                  "): another device or driver? the allocation outcomes below are for the pilot rendered now");
}

// The allocation comparison at equal samples over the protocol's draws; the scores in e.strategies.
Scores score_strategies(const Record& r, const EvalInputs& in, const alloc::PilotDiagnosis& d0,
                        const std::vector<double>& ref_rgb, const std::vector<uint8_t>& ref_labels, Evaluation& e) {
    const bool robust = !in.pilots[0].mom_var.empty();
    std::vector<Strategy> strategies;
    for (Strategy s : {Strategy::Uniform, Strategy::ObservedVar, Strategy::BucketFloor, Strategy::RobustVar,
                       Strategy::RobustFloor, Strategy::Guarded, Strategy::Shrink, Strategy::Placebo, Strategy::Oracle})
        if (robust || !alloc::needs_mom(s)) strategies.push_back(s);
    Scores sc;
    const alloc::ClassTraits traits = r.class_traits();
    for (uint32_t k = 0; k < r.protocol.draws; ++k) {
        const Pilot& pl = in.pilots[k];
        const alloc::PilotDiagnosis dg = k == 0 ? d0 : alloc::diagnose_pilot(pl, traits);
        alloc::ScoreInputs si;
        si.heavy = traits.heavy;
        si.rare = traits.rare;
        si.pilot_var = &pl.var;
        si.pilot_labels = &pl.labels;
        si.oracle_var = &in.pool->oracle_var;
        si.reference_labels = &ref_labels;
        if (!pl.mom_var.empty()) si.mom_var = &pl.mom_var;
        si.untrusted = &dg.untrusted_map;
        si.pilot_spp = r.pilot_spp;
        for (Strategy s : strategies) {
            const AdaptivePlan plan = plan_allocation(s, si, r.protocol.extra_spp, r.protocol.floor, 7919ull * (k + 1));
            StrategyScore& ss = sc.by_name[alloc::to_string(s)];
            ss.name = alloc::to_string(s);
            ss.mse.push_back(alloc::mse(final_image_rgb(*in.pool, plan.n), ref_rgb));
            sc.plans[ss.name].push_back(plan.n);
        }
    }
    const StrategyScore& uni = sc.by_name.at("uniform");
    for (Strategy s : strategies) {
        StrategyScore& ss = sc.by_name.at(alloc::to_string(s));
        std::vector<double> psnr;
        for (size_t k = 0; k < ss.mse.size(); ++k) {
            psnr.push_back(alloc::psnr(ss.mse[k], e.peak));
            ss.wins_vs_uniform += ss.mse[k] < uni.mse[k];
        }
        ss.psnr_mean = stats::mean(psnr);
        ss.psnr_std = psnr.size() > 1 ? std::sqrt(stats::sample_variance(psnr)) : 0.0;
        ss.identical_to_observed_var = sc.plans.at(ss.name)[0] == sc.plans.at("observed-var")[0];
        e.strategies.push_back(ss);
    }
    return sc;
}

// coverage.<bucket or class>.<pixel_share|energy_share>: the reference's share. `classes`: the slots' names.
void measure_coverage(const Prediction& pr, const DescriptorSummary& rs, const std::vector<std::string>& classes,
                      Outcome& o) {
    const std::string rest = pr.name.substr(9);
    const size_t dot = rest.rfind('.');
    const std::string bucket = rest.substr(0, dot), what = dot == std::string::npos ? "" : rest.substr(dot + 1);
    uint32_t b = 0;
    while (b < classes.size() && bucket != classes[b]) ++b;
    double m = NAN;
    if (b < classes.size() && b < kBucketCount)
        m = what == "pixel_share" ? rs.pixel_share[b] : what == "energy_share" ? rs.energy_share[b] : NAN;
    o.measured = fmt("%.4f", m);
    o.verdict = verdict_band(pr.value, m, pr.tolerance);
    o.detail =
        "the reference's " + what + " of " + bucket + " (" + std::to_string(rs.labelled_pixels) + " labelled pixels)";
}

// allocation.<a>_vs_<b>: the paired comparison of two strategies.
void measure_allocation(const Prediction& pr, const Scores& sc, Outcome& o) {
    const std::string pair = pr.name.substr(11);
    const size_t vs = pair.find("_vs_");
    const std::string a = pair.substr(0, vs), b = vs == std::string::npos ? "" : pair.substr(vs + 4);
    if (!sc.by_name.count(a) || !sc.by_name.count(b)) {
        o.measured = "not measured";
        o.verdict = "INDETERMINATE";
        o.detail = "the comparison lacks " + (sc.by_name.count(a) ? b : a);
        return;
    }
    const StrategyScore& A = sc.by_name.at(a);
    const StrategyScore& B = sc.by_name.at(b);
    const double diff = A.psnr_mean - B.psnr_mean;
    const alloc::Paired pw = alloc::paired_wins(A.mse, B.mse);
    size_t same = 0;
    for (size_t k = 0; k < sc.plans.at(a).size(); ++k) same += sc.plans.at(a)[k] == sc.plans.at(b)[k];
    const bool same0 = sc.plans.at(a)[0] == sc.plans.at(b)[0];
    if (pr.outcome == "no-op") {
        o.measured = same0 ? "identical" : "differs";
        o.verdict = same0 ? "PASS" : "FAIL";
    } else {
        o.measured = fmt("%+.3f dB", diff);
        const double n = static_cast<double>(A.mse.size());
        const alloc::Paired losses = alloc::paired_wins(B.mse, A.mse);  // draws where A's MSE is higher
        if (pr.outcome == "helps")
            o.verdict = !(diff > 0) ? "FAIL" : pw.wins >= kWinShare * n ? "PASS" : "INDETERMINATE";
        else if (pr.outcome == "fails")
            o.verdict = !(diff < 0) ? "FAIL" : losses.wins >= kWinShare * n ? "PASS" : "INDETERMINATE";
        else
            o.verdict = "INDETERMINATE";
    }
    o.detail = a + " " + fmt("%.2f", A.psnr_mean) + " dB vs " + b + " " + fmt("%.2f", B.psnr_mean) + " dB (mean over " +
               std::to_string(A.mse.size()) + " draws); lower MSE on " + std::to_string(pw.wins) + "/" +
               std::to_string(pw.draws) + " draws; identical allocation on " + std::to_string(same) + "/" +
               std::to_string(A.mse.size()) + " draws";
}

// structure.rho_CG_sign: the sign of the caustic/glossy correlation, with its tile-bootstrap interval.
void measure_structure(const Prediction& pr, const Frame& ref, const Descriptor& rd, Outcome& o) {
    const size_t P = static_cast<size_t>(ref.width) * ref.height;
    std::vector<double> cx, gx, cf(P, NAN), gf(P, NAN);
    bool cnz = false, gnz = false;
    for (size_t p = 0; p < P; ++p) {
        if (rd.dominant[p] == kNoLabel) continue;
        cx.push_back(rd.caustic_frac[p]);
        gx.push_back(rd.glossy_frac[p]);
        cf[p] = rd.caustic_frac[p];
        gf[p] = rd.glossy_frac[p];
        cnz = cnz || rd.caustic_frac[p] != 0.0f;
        gnz = gnz || rd.glossy_frac[p] != 0.0f;
    }
    if (!cnz || !gnz) {
        o.measured = "degenerate";
        o.verdict = "INDETERMINATE";
        o.detail =
            std::string("the reference has no ") + (cnz ? "glossy" : "delta-mediated") + " energy in a labelled pixel";
        return;
    }
    const double rho = stats::spearman(cx, gx);
    const stats::Interval ci = stats::tile_bootstrap_spearman(cf, gf, ref.width, 8, 1000, 0);
    o.measured = fmt("%+.3f", rho) + " [" + fmt("%+.3f", ci.lo) + ", " + fmt("%+.3f", ci.hi) + "]";
    const bool pos = ci.lo > 0, neg = ci.hi < 0;
    const bool want_pos = pr.outcome == "positive";
    o.verdict = (want_pos && pos) || (!want_pos && neg) ? "PASS" : (pos || neg) ? "FAIL" : "INDETERMINATE";
    o.detail = "Spearman rho of caustic_frac and glossy_frac over the reference's " + std::to_string(cx.size()) +
               " labelled pixels, 95% tile-bootstrap interval";
}

}  // namespace

Evaluation evaluate(const Record& r, const EvalInputs& in) {
    check_inputs(r, in);
    const Frame& ref = *in.reference;
    Evaluation e;
    // The reference: unclamped RGB, the PSNR peak, its descriptor.
    const std::vector<double> ref_rgb = mean_rgb(ref);
    e.peak = psnr_peak(ref_rgb);
    Descriptor rd = derive_descriptor(ref);
    if (r.taxonomy) use_taxonomy_classes(rd, r.taxonomy->classes);  // `other` is its last class
    const DescriptorSummary rs = summarize(ref, rd);
    const alloc::PilotDiagnosis d0 = alloc::diagnose_pilot(in.pilots[0], r.class_traits());
    check_reproduced(r, d0, e);
    const std::vector<uint8_t> ref_labels = rd.dominant;
    const Scores sc = score_strategies(r, in, d0, ref_rgb, ref_labels, e);

    // Every prediction, by the rule it was registered with.
    std::vector<uint8_t> pilot_labels = derive_descriptor(in.pilots[0].frame).dominant;
    const stats::Confusion conf = stats::confusion(pilot_labels, ref_labels, kBucketCount);
    const double agree = stats::agreement(conf);
    for (const Prediction& pr : r.predictions) {
        Outcome o;
        o.name = pr.name;
        o.covers = pr.covers;
        o.predicted = pr.outcome.empty() ? fmt("%.4f", pr.value) : pr.outcome;
        if (pr.name.rfind("reliability.", 0) == 0) {
            o.measured = fmt("%.4f", agree);
            o.verdict = verdict_band(pr.value, agree, pr.tolerance);
            o.detail = "agreement of the registered pilot's dominant labels with the reference's over " +
                       std::to_string(static_cast<uint64_t>(conf.total())) + " pixels labelled in both; |error| " +
                       fmt("%.4f", std::abs(agree - pr.value)) + " (band " + fmt("%.3f", pr.tolerance) + ")";
        } else if (pr.name.rfind("coverage.", 0) == 0) {
            measure_coverage(pr, rs, r.class_names(), o);
        } else if (pr.name.rfind("allocation.", 0) == 0) {
            measure_allocation(pr, sc, o);
        } else if (pr.name == "structure.rho_CG_sign") {
            measure_structure(pr, ref, rd, o);
        } else {
            o.measured = "not measured";
            o.verdict = "INDETERMINATE";
            o.detail = "this vkmech has no measurement for this prediction";
        }
        (o.verdict == "PASS" ? e.pass : o.verdict == "FAIL" ? e.fail : e.indeterminate) += 1;
        e.outcomes.push_back(std::move(o));
    }
    e.checks.push_back("the reference: " + std::to_string(r.protocol.reference_spp) +
                       " samples per pixel, `other` energy " + fmt("%.3g", rs.other_energy) + ", " +
                       std::to_string(rs.nonfinite_samples) + " non-finite samples");
    return e;
}

std::string evaluation_json(const Record& r, const std::string& record_sha256, const Evaluation& e) {
    std::ostringstream j;
    j << "{\n  \"format\": \"vkmech sentinel evaluation\",\n  \"format_version\": 1";
    j << ",\n  \"record\": {\"scene\": " << json_string(r.scene_name) << ", \"sha256\": " << json_string(record_sha256)
      << ", \"registered_utc\": " << json_string(r.registered_utc) << "}";
    j << ",\n  \"summary\": {\"pass\": " << e.pass << ", \"fail\": " << e.fail
      << ", \"indeterminate\": " << e.indeterminate
      << ", \"pilot_reproduced\": " << (e.pilot_reproduced ? "true" : "false")
      << ", \"psnr_peak\": " << json_number(e.peak) << "}";
    j << ",\n  \"outcomes\": [";
    for (size_t i = 0; i < e.outcomes.size(); ++i) {
        const Outcome& o = e.outcomes[i];
        j << (i ? "," : "") << "\n    {\"name\": " << json_string(o.name)
          << ", \"predicted\": " << json_string(o.predicted) << ", \"measured\": " << json_string(o.measured)
          << ", \"verdict\": " << json_string(o.verdict) << ", \"detail\": " << json_string(o.detail) << "}";
    }
    j << "\n  ],\n  \"strategies\": [";
    for (size_t i = 0; i < e.strategies.size(); ++i) {
        const StrategyScore& s = e.strategies[i];
        j << (i ? "," : "") << "\n    {\"name\": " << json_string(s.name)
          << ", \"psnr_mean\": " << json_number(s.psnr_mean) << ", \"psnr_std\": " << json_number(s.psnr_std)
          << ", \"wins_vs_uniform\": " << s.wins_vs_uniform << ", \"mse\": [";
        for (size_t k = 0; k < s.mse.size(); ++k) j << (k ? ", " : "") << json_number(s.mse[k]);
        j << "]}";
    }
    j << "\n  ],\n  \"checks\": [";
    for (size_t i = 0; i < e.checks.size(); ++i) j << (i ? ", " : "") << "\n    " << json_string(e.checks[i]);
    j << "\n  ]\n}\n";
    return j.str();
}

std::string evaluation_markdown(const Record& r, const std::string& record_file, const std::string& record_sha256,
                                const Evaluation& e, const std::vector<std::string>& renders) {
    std::ostringstream m;
    m << "# Sentinel evaluation: " << r.scene_name << "\n\n";
    m << "Record `" << record_file << "` (sha256 `" << record_sha256 << "`), registered " << r.registered_utc << " on "
      << r.device << " from a " << r.pilot_spp << "-spp pilot (seed " << r.pilot_seed << ") at " << r.width << "x"
      << r.height << ". Protocol (fixed at registration): reference " << r.protocol.reference_spp << " spp, "
      << r.protocol.draws << " pilot draws, extra budget " << r.protocol.extra_spp << " spp, floor " << r.protocol.floor
      << ".\n\n";
    if (r.taxonomy) {
        m << "Labels: the classes of the taxonomy `" << r.taxonomy->path << "` (sha256 `" << r.taxonomy->sha256
          << "`): ";
        for (size_t c = 0; c < r.taxonomy->classes.size(); ++c) m << (c ? ", " : "") << r.taxonomy->classes[c];
        m << ". Every render of the evaluation labels by it; the allocation rules read the classes its lines declare "
             "[heavy] and [constant].\n\n";
    }
    m << "**" << e.pass << " PASS, " << e.fail << " FAIL, " << e.indeterminate << " INDETERMINATE** of "
      << e.outcomes.size() << " predictions.\n\n";
    m << "| prediction | predicted | measured | verdict | how measured |\n|---|---|---|---|---|\n";
    for (const Outcome& o : e.outcomes)
        m << "| " << o.name << " | " << o.predicted << " | " << o.measured << " | " << o.verdict << " | " << o.detail
          << " |\n";
    m << "\n## Allocation at equal samples\n\nPSNR (dB) on unclamped linear RGB against the reference (peak "
      << fmt("%.4g", e.peak) << "), mean and seed std over " << r.protocol.draws
      << " pilot draws; final images are prefixes of one shared pool, so uniform has no spread.\n\n";
    m << "| strategy | PSNR | std | MSE wins vs uniform | = observed-var (registered draw) |\n|---|---|---|---|---|\n";
    for (const StrategyScore& s : e.strategies)
        m << "| " << s.name << " | " << fmt("%.2f", s.psnr_mean) << " | " << fmt("%.2f", s.psnr_std) << " | "
          << s.wins_vs_uniform << "/" << s.mse.size() << " | " << (s.identical_to_observed_var ? "yes" : "no")
          << " |\n";
    m << "\n## Checks\n\n";
    for (const std::string& c : e.checks) m << "- " << c << "\n";
    m << "\n## Renders made by the evaluation\n\n";
    for (const std::string& x : renders) m << "- " << x << "\n";
    return m.str();
}

}  // namespace vkmech::sentinel
