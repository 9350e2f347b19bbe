// Cross-scene correlation structure (paper §5, docs/descriptor.md §5): per-pixel Spearman
// among caustic_frac (C), glossy_frac (G), depth (D) and inv_purity (P), the
// separation measures between the delta-S and glossy object families, and
// the caustic/glossy correlation beside them (tab:sign-reversal).
#include "experiments/separation.hpp"
#include "experiments/study_context.hpp"
#include "stats/bootstrap.hpp"
#include "stats/rank.hpp"

#include <cmath>
#include <limits>
#include <map>

namespace vkmech {

using report::Cell;
using report::Table;

void run_structure(StudyContext& ctx) {
    const StudyConfig& cfg = ctx.cfg;
    const std::string sec = "Correlation structure";
    // Pair order as the paper's tab:correlation-matrix.
    const std::vector<std::pair<int, int>> pairs = {{0, 3}, {3, 1}, {0, 1}, {2, 0}, {2, 1}, {2, 3}};
    const char* abbrev[] = {"C", "G", "D", "P"};

    Table corr{"correlation_matrix",
               "Per-pixel Spearman rho among the four continuous components (tab:correlation-matrix)",
               {"pair"},
               {},
               ""};
    corr.note =
        "C = caustic_frac, G = glossy_frac, D = depth, P = inv_purity (1 - purity), over the reference render's "
        "labelled pixels. deg.: one component is identically zero in that scene.";
    Table sep{"sign_reversal",
              "Caustic/glossy correlation and object-space separation (tab:sign-reversal)",
              {"scene", "delta-S objects", "glossy objects", "min dist. (scene units)", "mut. vis.", "rho C-G",
               "rho C-G 95% CI"},
              {},
              ""};
    sep.note =
        "families by BSDF lobe flags: glossy = can sample a glossy lobe (rough conductor, rough dielectric, rough "
        "plastic, principled), delta-S = a delta lobe and no glossy one (smooth conductor, dielectric, thin "
        "dielectric, smooth plastic); min dist.: exact minimum surface-to-surface distance between any delta-S and "
        "any glossy object; mut. vis.: share of unoccluded segments between 64 surface points per object pair "
        "(ray-tested, offset 1e-3, seed 0). n/a: a family is empty. 95% CI: tile bootstrap of rho over the "
        "reference's labelled pixels (8 x 8-pixel tiles, 1000 resamples, seed 0): how much rho varies across "
        "image regions of this one render, not across seeds.";
    Table f2{"depth_purity",
             "Finding 2: rho(depth, inv_purity) per scene against the paper's sign",
             {"scene", "rho D-P", "95% CI", "paper", "reading"},
             {},
             ""};
    f2.note =
        "rho D-P: per-pixel Spearman of depth and 1 - purity over the reference's labelled pixels; 95% CI: tile "
        "bootstrap as in tab:sign-reversal. reading: holds when the interval lies on the paper's side of 0, "
        "differs when it lies on the other side, indeterminate when it contains 0.";
    for (const auto& s : cfg.scenes) corr.columns.push_back(s.name);
    std::vector<std::vector<Cell>> corr_rows;
    for (auto [a, b] : pairs) corr_rows.push_back({Cell::str(std::string(abbrev[a]) + " <-> " + abbrev[b])});

    std::map<std::string, std::pair<double, double>> vis_rho;  // scene -> (mutual visibility, rho C-G)
    std::map<std::string, double> rho_dp;                      // scene -> rho(depth, inv_purity) (Finding 2)
    std::map<std::string, stats::Interval> ci_cg, ci_dp;       // their tile-bootstrap intervals
    auto ci_str = [](const stats::Interval& i) {
        if (!std::isfinite(i.lo)) return std::string("n/a");
        std::string s = "[";  // appended piecewise: GCC 12 warns falsely (-Wrestrict) on "[" + std::string
        s += report::format("%+.3f", i.lo);
        s += ", ";
        s += report::format("%+.3f", i.hi);
        s += "]";
        return s;
    };
    report::Figure fig{"caustic_vs_glossy", "caustic_frac versus glossy_frac per pixel", "", 0, {}};

    for (const auto& scene : cfg.scenes) {
        Frame ref = ctx.frames.get(
            {scene, cfg.stability_reference_spp(), seeds::stability(cfg.stability_spp.size() - 1), Estimator::Nee});
        Descriptor d = derive_descriptor(ref);
        std::array<std::vector<double>, 4> comp;
        std::array<std::vector<double>, 4> field;  // the same per pixel, NaN where unlabelled (for the bootstrap)
        for (auto& f : field) f.assign(d.dominant.size(), std::numeric_limits<double>::quiet_NaN());
        std::array<bool, 4> nonzero{};
        for (size_t p = 0; p < d.dominant.size(); ++p) {
            if (d.dominant[p] == kNoLabel) continue;
            double v[4] = {d.caustic_frac[p], d.glossy_frac[p], d.depth[p], 1.0 - d.purity[p]};
            for (int k = 0; k < 4; ++k) {
                comp[k].push_back(v[k]);
                field[k][p] = v[k];
                nonzero[k] = nonzero[k] || v[k] != 0.0;
            }
        }
        for (size_t i = 0; i < pairs.size(); ++i) {
            auto [a, b] = pairs[i];
            corr_rows[i].push_back(nonzero[a] && nonzero[b] ? Cell::num(stats::spearman(comp[a], comp[b]), "%+.2f")
                                                            : Cell::str("deg."));
        }
        double rho_cg = nonzero[0] && nonzero[1] ? stats::spearman(comp[0], comp[1]) : NAN;
        rho_dp[scene.name] = nonzero[2] && nonzero[3] ? stats::spearman(comp[2], comp[3]) : NAN;
        const int w = static_cast<int>(ref.width);
        if (std::isfinite(rho_cg))
            ci_cg[scene.name] = stats::tile_bootstrap_spearman(field[0], field[1], w, 8, 1000, 0);
        if (std::isfinite(rho_dp[scene.name]))
            ci_dp[scene.name] = stats::tile_bootstrap_spearman(field[2], field[3], w, 8, 1000, 0);
        if (ctx.separation) {
            SeparationMeasures m = ctx.separation(scene);
            vis_rho[scene.name] = {m.mutual_visibility, rho_cg};
            sep.add({Cell::str(scene.name), Cell::integer(m.delta_objects), Cell::integer(m.glossy_objects),
                     Cell::num(m.min_distance, "%.3f", "n/a"), Cell::num(m.mutual_visibility, "%.3f", "n/a"),
                     Cell::num(rho_cg, "%+.3f", "deg."),
                     Cell::str(ci_cg.count(scene.name) ? ci_str(ci_cg[scene.name]) : "deg.")});
        }
        report::Panel p;
        p.kind = "scatter";
        p.title = scene.name + (std::isfinite(rho_cg) ? " (rho " + report::format("%+.2f", rho_cg) + ")" : " (deg.)");
        p.xlabel = "caustic_frac";
        p.ylabel = "glossy_frac";
        p.xlim = std::make_pair(-0.02, 1.02);
        p.ylim = std::make_pair(-0.02, 1.02);
        report::Series s{"", {}, {}, {}, {}, "#0072B2", "o", "", 3, 0.35, {}};
        size_t n = comp[0].size(), step = std::max<size_t>(1, n / 3000);  // deterministic subsample
        for (size_t i = 0; i < n; i += step) {
            s.x.push_back(comp[0][i]);
            s.y.push_back(comp[1][i]);
        }
        p.series.push_back(s);
        fig.panels.push_back(p);
    }
    for (auto& r : corr_rows) corr.add(r);
    if (vis_rho.count("tabletop_mixed") && vis_rho.count("tabletop_separated")) {
        auto [vm, rm] = vis_rho["tabletop_mixed"];
        auto [vs, rs] = vis_rho["tabletop_separated"];
        ctx.out.check("Finding 1: blocking the sight lines (tabletop_separated) lowers rho C-G below tabletop_mixed's",
                      rm > rs && vs < vm,
                      "tabletop_mixed: visibility " + report::format("%.3f", vm) + ", rho " +
                          report::format("%+.3f", rm) + "; tabletop_separated: visibility " +
                          report::format("%.3f", vs) + ", rho " + report::format("%+.3f", rs) +
                          " (paper: +0.441 vs -0.270, a sign reversal)");
        const stats::Interval im = ci_cg.count("tabletop_mixed") ? ci_cg["tabletop_mixed"] : stats::Interval{NAN, NAN};
        const stats::Interval is =
            ci_cg.count("tabletop_separated") ? ci_cg["tabletop_separated"] : stats::Interval{NAN, NAN};
        ctx.out.check(
            "Finding 1, the paper's strong form: rho C-G changes sign, positive on tabletop_mixed and negative on "
            "tabletop_separated, with 95% intervals that exclude 0",
            im.lo > 0 && is.hi < 0,
            "rho C-G " + report::format("%+.3f", rm) + " " + ci_str(im) + " (mixed) and " +
                report::format("%+.3f", rs) + " " + ci_str(is) + " (separated); paper: +0.441 and -0.270");
    }
    {
        // Finding 2 (paper §5, tab:correlation-matrix last row): the sign of rho(depth, inv_purity) separates the
        // specular-chain scenes (negative: snooker, ring_caustic) from the lobe-mixing ones (positive).
        const std::map<std::string, int> paper_sign = {
            {"cubes_dof", +1},       {"glass_caustic", +1}, {"tabletop_mixed", +1}, {"tabletop_separated", +1},
            {"kitchen_counter", +1}, {"snooker", -1},       {"ring_caustic", -1}};
        std::string detail, wrong, unsure;
        int compared = 0;
        for (const auto& scene : cfg.scenes) {
            auto ps = paper_sign.find(scene.name);
            auto it = rho_dp.find(scene.name);
            if (ps == paper_sign.end() || it == rho_dp.end()) continue;
            ++compared;
            const int sign = ps->second;
            const double r = it->second;
            const stats::Interval ci = ci_dp.count(scene.name) ? ci_dp[scene.name] : stats::Interval{NAN, NAN};
            const double lo = sign > 0 ? ci.lo : -ci.hi, hi = sign > 0 ? ci.hi : -ci.lo;  // on the paper's side: > 0
            const char* reading = !std::isfinite(lo) ? "n/a" : lo > 0 ? "holds" : hi < 0 ? "differs" : "indeterminate";
            f2.add({Cell::str(scene.name), Cell::num(r, "%+.3f", "deg."), Cell::str(ci_str(ci)),
                    Cell::str(sign > 0 ? "+" : "-"), Cell::str(reading)});
            detail += (detail.empty() ? "" : ", ") + scene.name + " " +
                      (std::isfinite(r) ? report::format("%+.2f", r) + " " + ci_str(ci) : std::string("deg.")) +
                      (sign > 0 ? " (paper +)" : " (paper -)");
            if (std::string(reading) == "indeterminate")
                unsure += (unsure.empty() ? "" : ", ") + scene.name;
            else if (std::string(reading) != "holds")
                wrong += (wrong.empty() ? "" : ", ") + scene.name;
        }
        if (compared > 0)
            ctx.out.check(
                "Finding 2: rho(depth, inv_purity) is negative on snooker and ring_caustic and positive on the "
                "other first-party scenes (95% intervals on the paper's side of 0)",
                wrong.empty() && unsure.empty(),
                detail + (wrong.empty() ? "" : "; sign differs on: " + wrong) +
                    (unsure.empty() ? "" : "; interval contains 0 on: " + unsure));
    }
    ctx.out.table(sec, corr,
                  "each cell is a per-pixel rank correlation within one scene; a pair whose sign flips across "
                  "scenes points at a scene-level variable (the paper's Findings 1 and 2).");
    if (!f2.rows.empty())
        ctx.out.table(sec, f2,
                      "Finding 2: the sign of the depth/purity correlation separates specular-chain scenes "
                      "(negative) from lobe-mixing ones (positive) in the paper; each row says whether this "
                      "render agrees, with its uncertainty.");
    if (!sep.rows.empty())
        ctx.out.table(sec, sep,
                      "Finding 1: the caustic/glossy correlation should follow the mutual visibility of the two "
                      "object families (positive when light paths can meet both, negative when separated).");
    ctx.out.figure(sec, fig, "one panel per scene; every point is a labelled pixel (subsampled to about 3000).");
}

}  // namespace vkmech
