// Cross-scene correlation structure (paper §5, docs/descriptor.md §5): per-pixel Spearman
// among caustic_frac (C), glossy_frac (G), depth (D) and inv_purity (P), the
// separation measures between the delta-S and glossy object families, and
// the caustic/glossy correlation beside them (tab:sign-reversal).
// Under --taxonomy (docs/lpe.md): the components are each class's share of the pixel's energy
// (but `other`'s), G, D and the taxonomy's own P, every pair of them; the caustic side of
// tab:sign-reversal is the [rare] classes' share; Findings 1 and 2, readings of the buckets, are not
// checked.
#include "experiments/separation.hpp"
#include "experiments/study_context.hpp"
#include "stats/bootstrap.hpp"
#include "stats/rank.hpp"

#include <cmath>
#include <limits>
#include <map>
#include <optional>

namespace vkmech {

using report::Cell;
using report::Table;
namespace {

// Pair order as the paper's tab:correlation-matrix; components C, G, D, P.
const std::vector<std::pair<int, int>> kPairs = {{0, 3}, {3, 1}, {0, 1}, {2, 0}, {2, 1}, {2, 3}};
const std::vector<std::string> kAbbrev = {"C", "G", "D", "P"};

// The continuous components, named as the correlation table names them: C, G, D, P; under a taxonomy
// "<class> share" for every class but `other`, then glossy_frac, depth and inv_purity.
struct Components {
    bool taxonomy = false;
    std::vector<std::string> names;
    std::vector<StudyClass> shares;  // the taxonomy's classes whose shares lead the list (none for the buckets)
    std::vector<std::pair<int, int>> pairs;
    std::vector<StudyClass> rare;  // the [rare] classes: tab:sign-reversal's caustic side under a taxonomy
};

Components components(const StudyConfig& cfg) {
    Components c;
    if (!cfg.taxonomy) {
        c.names = kAbbrev;
        c.pairs = kPairs;
        return c;
    }
    c.taxonomy = true;
    const std::vector<StudyClass> classes = study_classes(cfg, {});
    for (size_t i = 0; i + 1 < classes.size(); ++i) {  // every class but `other`, the last
        c.shares.push_back(classes[i]);
        c.names.push_back(classes[i].name + " share");
        if (classes[i].rare) c.rare.push_back(classes[i]);
    }
    for (const char* n : {"glossy_frac", "depth", "inv_purity"}) c.names.push_back(n);
    for (int a = 0; a < static_cast<int>(c.names.size()); ++a)
        for (int b = a + 1; b < static_cast<int>(c.names.size()); ++b) c.pairs.push_back({a, b});
    return c;
}

// Pixel p's components in the order of c.names, and the caustic side of rho C-G (caustic_frac, or the
// [rare] classes' share) in *caustic.
std::vector<double> component_values(const Components& c, const Frame& ref, const Descriptor& d, size_t p,
                                     double* caustic) {
    std::vector<double> v;
    if (!c.taxonomy) {
        v = {d.caustic_frac[p], d.glossy_frac[p], d.depth[p], 1.0 - d.purity[p]};
        *caustic = v[0];
        return v;
    }
    const std::array<double, kBucketCount> share = slot_shares(ref.pixels[p]);
    for (const StudyClass& k : c.shares)  // in float, as derive_descriptor's caustic_frac
        v.push_back(static_cast<float>(share[k.slot]));
    double rare = 0.0;
    for (const StudyClass& k : c.rare) rare += static_cast<float>(share[k.slot]);
    *caustic = rare;
    v.insert(v.end(), {d.glossy_frac[p], d.depth[p], 1.0 - d.purity[p]});
    return v;
}

// ---- compute: per scene the component correlations, their intervals and the separation measures ----

struct StructureScene {
    std::string name;
    std::vector<std::optional<double>> pair_rho;  // per pair of kPairs; none: a component is identically zero
    double rho_cg = NAN, rho_dp = NAN;
    std::optional<stats::Interval> ci_cg, ci_dp;  // tile-bootstrap intervals where the rho is finite
    std::optional<SeparationMeasures> separation;
    std::vector<double> scatter_c, scatter_g;  // a deterministic subsample of (C, G) per labelled pixel
};

StructureScene structure_scene(StudyContext& ctx, const SceneVariant& scene, const Components& c) {
    const StudyConfig& cfg = ctx.cfg;
    StructureScene r;
    r.name = scene.name;
    Frame ref = ctx.frames.get(
        {scene, cfg.stability_reference_spp(), seeds::stability(cfg.stability_spp.size() - 1), Estimator::Nee});
    Descriptor d = derive_descriptor(ref);
    // The components, then the caustic side of rho C-G (caustic_frac, or the [rare] classes' share) last.
    const size_t K = c.names.size(), C = K;
    const size_t G = K - 3, D = K - 2, P = K - 1;  // glossy_frac, depth and inv_purity close every list
    std::vector<std::vector<double>> comp(K + 1);
    std::vector<std::vector<double>> field(K + 1);  // the same per pixel, NaN where unlabelled (for the bootstrap)
    for (auto& f : field) f.assign(d.dominant.size(), std::numeric_limits<double>::quiet_NaN());
    std::vector<bool> nonzero(K + 1, false);
    for (size_t p = 0; p < d.dominant.size(); ++p) {
        if (d.dominant[p] == kNoLabel) continue;
        double caustic = 0.0;
        std::vector<double> v = component_values(c, ref, d, p, &caustic);
        v.push_back(caustic);
        for (size_t k = 0; k <= K; ++k) {
            comp[k].push_back(v[k]);
            field[k][p] = v[k];
            nonzero[k] = nonzero[k] || v[k] != 0.0;
        }
    }
    for (auto [a, b] : c.pairs)
        r.pair_rho.push_back(nonzero[a] && nonzero[b] ? std::optional(stats::spearman(comp[a], comp[b]))
                                                      : std::nullopt);
    const bool has_caustic = !c.taxonomy || !c.rare.empty();
    r.rho_cg = has_caustic && nonzero[C] && nonzero[G] ? stats::spearman(comp[C], comp[G]) : NAN;
    r.rho_dp = nonzero[D] && nonzero[P] ? stats::spearman(comp[D], comp[P]) : NAN;
    const int w = static_cast<int>(ref.width);
    if (std::isfinite(r.rho_cg)) r.ci_cg = stats::tile_bootstrap_spearman(field[C], field[G], w, 8, 1000, 0);
    if (std::isfinite(r.rho_dp)) r.ci_dp = stats::tile_bootstrap_spearman(field[D], field[P], w, 8, 1000, 0);
    if (ctx.separation) r.separation = ctx.separation(scene);
    size_t n = comp[C].size(), step = std::max<size_t>(1, n / 3000);  // deterministic subsample
    for (size_t i = 0; has_caustic && i < n; i += step) {
        r.scatter_c.push_back(comp[C][i]);
        r.scatter_g.push_back(comp[G][i]);
    }
    return r;
}

std::vector<StructureScene> compute_structure(StudyContext& ctx, const Components& c) {
    std::vector<StructureScene> r;
    for (const auto& scene : ctx.cfg.scenes) r.push_back(structure_scene(ctx, scene, c));
    return r;
}

// ---- writers ----

std::string ci_str(const stats::Interval& i) {
    if (!std::isfinite(i.lo)) return std::string("n/a");
    std::string s = "[";  // appended piecewise: GCC 12 warns falsely (-Wrestrict) on "[" + std::string
    s += report::format("%+.3f", i.lo);
    s += ", ";
    s += report::format("%+.3f", i.hi);
    s += "]";
    return s;
}

Table correlation_table(const std::vector<StructureScene>& r, const Components& c, const StudyConfig& cfg) {
    Table corr{"correlation_matrix",
               c.taxonomy ? "Per-pixel Spearman rho among the classes' shares, glossy_frac, depth and inv_purity"
                          : "Per-pixel Spearman rho among the four continuous components (tab:correlation-matrix)",
               {"pair"},
               {},
               ""};
    corr.note =
        c.taxonomy
            ? "Classes of the taxonomy " + cfg.taxonomy->file +
                  ": <class> share = the class's share of the pixel's energy (every class but other), glossy_frac, "
                  "depth, inv_purity = 1 - the taxonomy's purity, over the reference render's labelled pixels; "
                  "every pair. deg.: one component is identically zero in that scene."
            : "C = caustic_frac, G = glossy_frac, D = depth, P = inv_purity (1 - purity), over the reference render's "
              "labelled pixels. deg.: one component is identically zero in that scene.";
    for (const auto& sc : r) corr.columns.push_back(sc.name);
    for (size_t i = 0; i < c.pairs.size(); ++i) {
        auto [a, b] = c.pairs[i];
        std::vector<Cell> row{Cell::str(c.names[a] + " <-> " + c.names[b])};
        for (const auto& sc : r)
            row.push_back(sc.pair_rho[i] ? Cell::num(*sc.pair_rho[i], "%+.2f") : Cell::str("deg."));
        corr.add(row);
    }
    return corr;
}

// The caustic side of rho C-G under a taxonomy, for the notes: its [rare] classes.
std::string rare_names(const Components& c) {
    std::string s;
    for (const StudyClass& k : c.rare) s += (s.empty() ? "" : ", ") + k.name;
    return s;
}

Table separation_table(const std::vector<StructureScene>& r, const Components& c) {
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
    if (c.taxonomy)
        sep.note += c.rare.empty() ? " rho C-G: the taxonomy declares no class [rare], so there is no caustic side."
                                   : " C: the share of the classes the taxonomy declares [rare] (" + rare_names(c) +
                                         ") in place of caustic_frac.";
    const char* none = c.taxonomy && c.rare.empty() ? "no [rare]" : "deg.";
    std::map<std::string, stats::Interval> ci_cg;  // by scene name, as the rows read them
    for (const auto& sc : r)
        if (sc.ci_cg) ci_cg[sc.name] = *sc.ci_cg;
    for (const auto& sc : r) {
        if (!sc.separation) continue;
        const SeparationMeasures& m = *sc.separation;
        sep.add({Cell::str(sc.name), Cell::integer(m.delta_objects), Cell::integer(m.glossy_objects),
                 Cell::num(m.min_distance, "%.3f", "n/a"), Cell::num(m.mutual_visibility, "%.3f", "n/a"),
                 Cell::num(sc.rho_cg, "%+.3f", none), Cell::str(ci_cg.count(sc.name) ? ci_str(ci_cg[sc.name]) : none)});
    }
    return sep;
}

// Finding 1: the caustic/glossy correlation follows the mutual visibility of the two object families.
void check_finding_1(StudyOutput& out, const std::vector<StructureScene>& r) {
    std::map<std::string, std::pair<double, double>> vis_rho;  // scene -> (mutual visibility, rho C-G)
    std::map<std::string, stats::Interval> ci_cg;
    for (const auto& sc : r) {
        if (sc.ci_cg) ci_cg[sc.name] = *sc.ci_cg;
        if (sc.separation) vis_rho[sc.name] = {sc.separation->mutual_visibility, sc.rho_cg};
    }
    if (!vis_rho.count("tabletop_mixed") || !vis_rho.count("tabletop_separated")) return;
    auto [vm, rm] = vis_rho["tabletop_mixed"];
    auto [vs, rs] = vis_rho["tabletop_separated"];
    out.check("Finding 1: blocking the sight lines (tabletop_separated) lowers rho C-G below tabletop_mixed's",
              rm > rs && vs < vm,
              "tabletop_mixed: visibility " + report::format("%.3f", vm) + ", rho " + report::format("%+.3f", rm) +
                  "; tabletop_separated: visibility " + report::format("%.3f", vs) + ", rho " +
                  report::format("%+.3f", rs) + " (paper: +0.441 vs -0.270, a sign reversal)");
    const stats::Interval im = ci_cg.count("tabletop_mixed") ? ci_cg["tabletop_mixed"] : stats::Interval{NAN, NAN};
    const stats::Interval is =
        ci_cg.count("tabletop_separated") ? ci_cg["tabletop_separated"] : stats::Interval{NAN, NAN};
    out.check(
        "Finding 1, the paper's strong form: rho C-G changes sign, positive on tabletop_mixed and negative on "
        "tabletop_separated, with 95% intervals that exclude 0",
        im.lo > 0 && is.hi < 0,
        "rho C-G " + report::format("%+.3f", rm) + " " + ci_str(im) + " (mixed) and " + report::format("%+.3f", rs) +
            " " + ci_str(is) + " (separated); paper: +0.441 and -0.270");
}

// Finding 2 (paper §5, tab:correlation-matrix last row): the sign of rho(depth, inv_purity) separates the
// specular-chain scenes (negative: snooker, ring_caustic) from the lobe-mixing ones (positive). Returns its table.
Table finding_2(StudyOutput& out, const std::vector<StructureScene>& r) {
    Table f2{"depth_purity",
             "Finding 2: rho(depth, inv_purity) per scene against the paper's sign",
             {"scene", "rho D-P", "95% CI", "paper", "reading"},
             {},
             ""};
    f2.note =
        "rho D-P: per-pixel Spearman of depth and 1 - purity over the reference's labelled pixels; 95% CI: tile "
        "bootstrap as in tab:sign-reversal. reading: holds when the interval lies on the paper's side of 0, "
        "differs when it lies on the other side, indeterminate when it contains 0.";
    const std::map<std::string, int> paper_sign = {
        {"cubes_dof", +1},       {"glass_caustic", +1}, {"tabletop_mixed", +1}, {"tabletop_separated", +1},
        {"kitchen_counter", +1}, {"snooker", -1},       {"ring_caustic", -1}};
    std::map<std::string, double> rho_dp;          // scene -> rho(depth, inv_purity), by name
    std::map<std::string, stats::Interval> ci_dp;  // its tile-bootstrap interval
    for (const auto& sc : r) {
        rho_dp[sc.name] = sc.rho_dp;
        if (sc.ci_dp) ci_dp[sc.name] = *sc.ci_dp;
    }
    std::string detail, wrong, unsure;
    int compared = 0;
    for (const auto& sc : r) {
        auto ps = paper_sign.find(sc.name);
        if (ps == paper_sign.end()) continue;
        ++compared;
        const int sign = ps->second;
        const double rho = rho_dp.at(sc.name);
        const stats::Interval ci = ci_dp.count(sc.name) ? ci_dp[sc.name] : stats::Interval{NAN, NAN};
        const double lo = sign > 0 ? ci.lo : -ci.hi, hi = sign > 0 ? ci.hi : -ci.lo;  // on the paper's side: > 0
        const char* reading = !std::isfinite(lo) ? "n/a" : lo > 0 ? "holds" : hi < 0 ? "differs" : "indeterminate";
        f2.add({Cell::str(sc.name), Cell::num(rho, "%+.3f", "deg."), Cell::str(ci_str(ci)),
                Cell::str(sign > 0 ? "+" : "-"), Cell::str(reading)});
        detail += (detail.empty() ? "" : ", ") + sc.name + " " +
                  (std::isfinite(rho) ? report::format("%+.2f", rho) + " " + ci_str(ci) : std::string("deg.")) +
                  (sign > 0 ? " (paper +)" : " (paper -)");
        if (std::string(reading) == "indeterminate")
            unsure += (unsure.empty() ? "" : ", ") + sc.name;
        else if (std::string(reading) != "holds")
            wrong += (wrong.empty() ? "" : ", ") + sc.name;
    }
    if (compared > 0)
        out.check(
            "Finding 2: rho(depth, inv_purity) is negative on snooker and ring_caustic and positive on the "
            "other first-party scenes (95% intervals on the paper's side of 0)",
            wrong.empty() && unsure.empty(),
            detail + (wrong.empty() ? "" : "; sign differs on: " + wrong) +
                (unsure.empty() ? "" : "; interval contains 0 on: " + unsure));
    return f2;
}

report::Figure scatter_figure(const std::vector<StructureScene>& r, const Components& c) {
    const std::string x = c.taxonomy ? "[rare] share" : "caustic_frac";
    report::Figure fig{"caustic_vs_glossy", x + " versus glossy_frac per pixel", "", 0, {}};
    for (const auto& sc : r) {
        report::Panel p;
        p.kind = "scatter";
        p.title =
            sc.name + (std::isfinite(sc.rho_cg) ? " (rho " + report::format("%+.2f", sc.rho_cg) + ")" : " (deg.)");
        p.xlabel = x;
        p.ylabel = "glossy_frac";
        p.xlim = std::make_pair(-0.02, 1.02);
        p.ylim = std::make_pair(-0.02, 1.02);
        report::Series s{"", {}, {}, {}, {}, "#0072B2", "o", "", 3, 0.35, {}};
        s.x = sc.scatter_c;
        s.y = sc.scatter_g;
        p.series.push_back(s);
        fig.panels.push_back(p);
    }
    return fig;
}

void write_structure(StudyOutput& out, const StudyConfig& cfg, const std::vector<StructureScene>& r,
                     const Components& c) {
    const std::string sec = "Correlation structure";
    const Table corr = correlation_table(r, c, cfg), sep = separation_table(r, c);
    Table f2;
    if (c.taxonomy) {  // the paper's Findings are readings of caustic_frac and of the buckets' purity
        out.text(sec, taxonomy_labels_lead(cfg) +
                          ". Findings 1 and 2 are the paper's readings of caustic_frac and of the "
                          "buckets' purity, so they are not checked; the correlation table has every pair of the "
                          "classes' shares, glossy_frac, depth and the taxonomy's inv_purity.");
    } else {
        check_finding_1(out, r);
        f2 = finding_2(out, r);
    }
    out.table(sec, corr,
              std::string("each cell is a per-pixel rank correlation within one scene; a pair whose sign flips "
                          "across scenes points at a scene-level variable") +
                  (c.taxonomy ? "." : " (the paper's Findings 1 and 2)."));
    if (!f2.rows.empty())
        out.table(sec, f2,
                  "Finding 2: the sign of the depth/purity correlation separates specular-chain scenes "
                  "(negative) from lobe-mixing ones (positive) in the paper; each row says whether this "
                  "render agrees, with its uncertainty.");
    if (!sep.rows.empty())
        out.table(sec, sep,
                  c.taxonomy ? "the separation of the delta-S and glossy object families beside the correlation of "
                               "the [rare] classes' share with glossy_frac (the paper's Finding 1 reads it with "
                               "caustic_frac)."
                             : "Finding 1: the caustic/glossy correlation should follow the mutual visibility of the "
                               "two object families (positive when light paths can meet both, negative when "
                               "separated).");
    if (!c.taxonomy || !c.rare.empty())
        out.figure(sec, scatter_figure(r, c),
                   "one panel per scene; every point is a labelled pixel (subsampled to about 3000).");
}

}  // namespace

void run_structure(StudyContext& ctx) {
    const Components c = components(ctx.cfg);
    write_structure(ctx.out, ctx.cfg, compute_structure(ctx, c), c);
}

}  // namespace vkmech
