// Cross-SPP stability of the dominant label (paper §4.3, docs/descriptor.md §5): agreement,
// max drift, Cohen's and weighted kappa, struct%, the quantile-binned
// variance baseline, coverage (`other` = 0), and restricted-MIS robustness
// (paper §4.4).
#include "experiments/study_context.hpp"
#include "render/render_outputs.hpp"
#include "stats/agreement.hpp"
#include "stats/bootstrap.hpp"
#include "stats/quantiles.hpp"

#include <cmath>

namespace vkmech {

using report::Cell;
using report::Table;

namespace {

const std::array<uint8_t, 3> kAgreeGrey{150, 150, 150}, kLightBlue{0, 114, 178}, kStructRed{213, 94, 0};

// Agreement class per pixel: 0 agree, 1 light-tailed swap, 2 structural swap, 255 unlabelled in either.
std::vector<uint8_t> agreement_classes(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
    std::vector<uint8_t> c(a.size(), 255);
    const auto& heavy = heavy_buckets();
    for (size_t i = 0; i < a.size(); ++i) {
        if (a[i] == kNoLabel || b[i] == kNoLabel) continue;
        if (a[i] == b[i])
            c[i] = 0;
        else
            c[i] = (heavy[a[i]] || heavy[b[i]]) ? 2 : 1;
    }
    return c;
}

// Binned-variance labels over the pixels labelled in both renders (others 255).
std::vector<uint8_t> variance_bins(const std::vector<double>& var, const std::vector<uint8_t>& mask_a,
                                   const std::vector<uint8_t>& mask_b, int bins) {
    std::vector<double> vals;
    for (size_t i = 0; i < var.size(); ++i)
        if (mask_a[i] != kNoLabel && mask_b[i] != kNoLabel) vals.push_back(var[i]);
    std::vector<uint8_t> out(var.size(), 255);
    if (vals.empty()) return out;
    auto edges = stats::quantile_edges(vals, bins);  // docs/descriptor.md §5: edges per SPP level
    auto binned = stats::quantile_bin(vals, edges);
    for (size_t i = 0, j = 0; i < var.size(); ++i)
        if (mask_a[i] != kNoLabel && mask_b[i] != kNoLabel) out[i] = binned[j++];
    return out;
}

// Nearest-neighbour enlargement so that small study films stay legible (about 256 px wide).
std::vector<uint8_t> enlarge(const std::vector<uint8_t>& cls, int w, int h, int s) {
    std::vector<uint8_t> out(static_cast<size_t>(w) * s * h * s);
    for (int y = 0; y < h * s; ++y)
        for (int x = 0; x < w * s; ++x)
            out[static_cast<size_t>(y) * w * s + x] = cls[static_cast<size_t>(y / s) * w + x / s];
    return out;
}

std::string scene_file_name(const std::string& name) {
    std::string s;
    for (char c : name) s += (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.') ? c : '_';
    return s;
}

}  // namespace

void run_stability(StudyContext& ctx) {
    const StudyConfig& cfg = ctx.cfg;
    const size_t nl = cfg.stability_spp.size();
    const std::string top = std::to_string(cfg.stability_reference_spp());
    const std::string pilot = std::to_string(cfg.pilot_spp());
    const std::string sec = "Cross-SPP stability";
    const int K = static_cast<int>(kBucketCount);

    Table cross{"cross_spp", "Cross-SPP stability of the dominant label (tab:cross-spp)", {"scene"}, {}, ""};
    for (size_t i = 0; i + 1 < nl; ++i) cross.columns.push_back(std::to_string(cfg.stability_spp[i]) + " vs " + top);
    cross.columns.push_back("max drift");
    cross.columns.push_back("labelled in one only");
    cross.note =
        "agree: share of pixels labelled in both renders whose dominant bucket matches. max drift: the largest "
        "change of any bucket's pixel share between " +
        pilot + " and " + top + " SPP.";
    Table kappa{"kappa",
                "Chance-corrected agreement, " + pilot + " vs " + top + " SPP (tab:kappa)",
                {"scene", "raw", "raw 95% CI", "Cohen kappa", "kappa 95% CI", "weighted kappa", "struct%"},
                {},
                ""};
    kappa.note =
        "Weighted kappa: agreement weight 1 - penalty, penalty 0.2 for a swap inside {emitter-direct, direct, "
        "diffuse-indirect}, 1.0 otherwise. struct%: share of disagreeing pixels whose swap touches {glossy, "
        "delta-mediated, specular-direct}. 95% CI: percentile interval of a tile bootstrap (8 x 8-pixel "
        "tiles resampled with replacement, 2000 resamples, seed 0): labels are spatially correlated, so "
        "tiles rather than pixels are the resampled units.";
    Table ev_pixels{"end_vertex_pixels",
                    "The two end-vertex readings (docs/descriptor.md §2): dominant-bucket pixel shares at " + top +
                        " SPP and " + pilot + "-vs-" + top + " agreement",
                    {"scene", "reading"},
                    {},
                    ""};
    for (const char* b : kBucketNames) ev_pixels.columns.push_back(b);
    ev_pixels.columns.push_back(pilot + " vs " + top);
    ev_pixels.columns.push_back("labels changed vs default");
    ev_pixels.columns.push_back("specular-direct -> delta-mediated");
    ev_pixels.note =
        "last-nondelta (the default): the end vertex is the last non-delta vertex and the delta flag looks at "
        "every other vertex, so a caustic seen on a diffuse surface (E-D-S-L) is delta_mediated. literal: "
        "the end vertex is the one before the light, so the same path is specular_direct. Same seeds for "
        "both readings; labels changed: share of the pixels labelled under both readings at " +
        top +
        " SPP whose dominant bucket differs; specular-direct -> delta-mediated: share of those pixels "
        "that are specular_direct under the literal reading and delta_mediated under the default, the "
        "caustic pixels the two readings disagree on.";
    Table ev_energy{"end_vertex_energy",
                    "The two end-vertex readings: energy share of each bucket at " + top + " SPP",
                    {"scene", "reading"},
                    {},
                    ""};
    for (const char* b : kBucketNames) ev_energy.columns.push_back(b);
    std::string caustic_default, caustic_literal;
    bool caustic_default_ok = true, saw_caustic = false;
    Table disc{"discretized_sigma",
               "Quantile-binned variance vs the label, " + pilot + " vs " + top + " SPP (tab:discretized-sigma)",
               {"scene", "3-bin sigma^2", "7-bin sigma^2", "mechanism", "label / 3-bin", "label / 7-bin"},
               {},
               ""};
    disc.note =
        "sigma^2 = the per-pixel sample variance of luminance of each render; bin edges are quantiles computed "
        "independently at each SPP level over the pixels labelled in both renders; scored with the label's "
        "agreement metric.";
    Table mis{"robust_mis",
              "Robustness to estimator completeness (tab:robust-mis)",
              {"scene", "MIS agree (" + top + ", disjoint seeds)", "NEE agree (" + top + ", disjoint seeds)",
               "MIS agree (" + top + ", same seed)", "cross-SPP (MIS)", "cross-SPP (NEE)"},
              {},
              ""};
    mis.note =
        "MIS agree: argmax agreement between the NEE-only estimator and the restricted power-heuristic MIS "
        "(docs/descriptor.md §1, `--estimator mis-restricted`) at " +
        top +
        " SPP, on the NEE reference's own seed "
        "(the estimators differ, the random numbers mostly do not) and on a disjoint seed (estimator and sampling "
        "noise together). NEE agree (disjoint seeds): two NEE renders at " +
        top +
        " SPP on disjoint seeds, the "
        "noise floor the disjoint-seed MIS figure is to be read against. cross-SPP: " +
        pilot + " vs " + top + " agreement under each estimator.";
    Table cov{"coverage",
              "Coverage: energy in `other` and bucket-sum closure per render",
              {"scene", "render", "other energy share", "max |sum_b L_b - lum| / lum", "non-finite samples",
               "labelled pixels"},
              {},
              ""};
    cov.note =
        "docs/descriptor.md §3: the seven buckets partition the luminance; `other` is expected to receive 0 on every "
        "scene.";
    Table shares{"bucket_shares", "Pixel share of each dominant bucket per SPP level", {"scene", "SPP"}, {}, ""};
    for (const char* b : kBucketNames) shares.columns.push_back(b);

    // Shape checks (docs/descriptor.md §7: other 0 everywhere; the label out-agrees binned variance on every scene).
    double worst_other = 0.0;
    std::string label_vs_var_fail;
    std::string other_where;

    report::Figure bars{"per_bucket_stability", "Per-bucket stability of the dominant label", "", 0, {}};

    for (const auto& scene : cfg.scenes) {
        std::vector<Frame> frames;
        std::vector<Descriptor> desc;
        for (size_t i = 0; i < nl; ++i) {
            frames.push_back(ctx.frames.get({scene, cfg.stability_spp[i], seeds::stability(i), Estimator::Nee}));
            desc.push_back(derive_descriptor(frames.back()));
        }
        Frame mis_pilot = ctx.frames.get({scene, cfg.pilot_spp(), seeds::stability(0), Estimator::MisRestricted});
        Frame mis_ref =
            ctx.frames.get({scene, cfg.stability_reference_spp(), seeds::stability(nl - 1), Estimator::MisRestricted});
        Descriptor dmp = derive_descriptor(mis_pilot), dmr = derive_descriptor(mis_ref);
        const auto& ref = desc.back().dominant;
        const auto& pil = desc.front().dominant;

        std::vector<Cell> row{Cell::str(scene.name)};
        for (size_t i = 0; i + 1 < nl; ++i)
            row.push_back(Cell::pct(stats::agreement(stats::confusion(desc[i].dominant, ref, K))));
        row.push_back(Cell::pct(stats::max_drift(pil, ref, K)));
        row.push_back(Cell::integer(static_cast<long long>(stats::labelled_in_one_only(pil, ref))));
        cross.add(row);

        auto conf = stats::confusion(pil, ref, K);
        double raw = stats::agreement(conf);
        auto ci = [&](const std::function<double(const stats::Confusion&)>& f) {
            stats::Interval i = stats::tile_bootstrap(pil, ref, K, frames.back().width, 8, f, 2000, 0);
            return Cell::str("[" + report::format("%.3f", i.lo) + ", " + report::format("%.3f", i.hi) + "]");
        };
        kappa.add(
            {Cell::str(scene.name), Cell::num(raw), ci([](const stats::Confusion& c) { return stats::agreement(c); }),
             Cell::num(stats::cohen_kappa(conf)), ci([](const stats::Confusion& c) { return stats::cohen_kappa(c); }),
             Cell::num(stats::weighted_kappa(conf, stats::spec_kappa_weights(K, light_tailed_buckets()))),
             Cell::pct(stats::structural_share(conf, heavy_buckets()), 1)});

        auto var_p = lum_var_field(frames.front()), var_r = lum_var_field(frames.back());
        double a3 =
            stats::agreement(stats::confusion(variance_bins(var_p, pil, ref, 3), variance_bins(var_r, pil, ref, 3), 3));
        double a7 =
            stats::agreement(stats::confusion(variance_bins(var_p, pil, ref, 7), variance_bins(var_r, pil, ref, 7), 7));
        if (!(raw > a3 && raw > a7)) label_vs_var_fail += (label_vs_var_fail.empty() ? "" : ", ") + scene.name;
        disc.add({Cell::str(scene.name), Cell::num(a3), Cell::num(a7), Cell::num(raw), Cell::num(raw / a3, "%.2fx"),
                  Cell::num(raw / a7, "%.2fx")});

        double mis_agree = stats::agreement(stats::confusion(ref, dmr.dominant, K));
        const Descriptor mis_disjoint = derive_descriptor(ctx.frames.get(
            {scene, cfg.stability_reference_spp(), seeds::mis_disjoint_reference(), Estimator::MisRestricted}));
        const Descriptor nee_disjoint = derive_descriptor(
            ctx.frames.get({scene, cfg.stability_reference_spp(), seeds::nee_disjoint_reference(), Estimator::Nee}));
        mis.add({Cell::str(scene.name), Cell::pct(stats::agreement(stats::confusion(ref, mis_disjoint.dominant, K))),
                 Cell::pct(stats::agreement(stats::confusion(ref, nee_disjoint.dominant, K))), Cell::pct(mis_agree),
                 Cell::pct(stats::agreement(stats::confusion(dmp.dominant, dmr.dominant, K))), Cell::pct(raw)});

        // The two end-vertex readings side by side (same seeds).
        std::vector<uint8_t> literal_ref;  // the literal reading's reference labels, for the maps below
        {
            const Frame lit_ref = ctx.frames.get(
                {scene, cfg.stability_reference_spp(), seeds::stability(nl - 1), Estimator::Nee, EndVertex::Literal});
            const Frame lit_pil =
                ctx.frames.get({scene, cfg.pilot_spp(), seeds::stability(0), Estimator::Nee, EndVertex::Literal});
            const Descriptor dlr = derive_descriptor(lit_ref), dlp = derive_descriptor(lit_pil);
            const DescriptorSummary sdef = summarize(frames.back(), desc.back()), slit = summarize(lit_ref, dlr);
            literal_ref = dlr.dominant;
            auto rows = [&](const std::string& reading, const std::vector<uint8_t>& r, const std::vector<uint8_t>& p,
                            const DescriptorSummary& sm, double changed, double moved) {
                std::vector<Cell> pr{Cell::str(scene.name), Cell::str(reading)},
                    er{Cell::str(scene.name), Cell::str(reading)};
                auto sh = stats::pixel_shares(r, K);
                for (int b = 0; b < K; ++b) {
                    pr.push_back(Cell::pct(sh[b]));
                    er.push_back(Cell::pct(sm.energy_share[b]));
                }
                pr.push_back(Cell::pct(stats::agreement(stats::confusion(p, r, K))));
                pr.push_back(std::isnan(changed) ? Cell::str("") : Cell::pct(changed));
                pr.push_back(std::isnan(moved) ? Cell::str("") : Cell::pct(moved));
                ev_pixels.add(pr);
                ev_energy.add(er);
                return sh[gpu::BUCKET_DELTA_MEDIATED];
            };
            const stats::Confusion lit_vs_def =
                stats::confusion(dlr.dominant, ref, K);  // rows literal, columns default
            const double changed = 1.0 - stats::agreement(lit_vs_def);
            const double both = static_cast<double>(lit_vs_def.total());
            const double moved =
                both > 0 ? lit_vs_def.at(gpu::BUCKET_SPECULAR_DIRECT, gpu::BUCKET_DELTA_MEDIATED) / both : 0.0;
            const double dm_def = rows("last-nondelta", ref, pil, sdef, NAN, NAN);
            const double dm_lit = rows("literal", dlr.dominant, dlp.dominant, slit, changed, moved);
            if (scene.name == "ring_caustic" || scene.name == "glass_caustic") {
                // Surfaces seen through glass are delta_mediated under both readings, so the check is on the
                // pixels the readings disagree on: caustics on diffuse surfaces, specular_direct -> delta_mediated.
                saw_caustic = true;
                caustic_default_ok = caustic_default_ok && moved >= 0.005;
                caustic_default +=
                    (caustic_default.empty() ? "" : ", ") + scene.name + " " + report::format("%.1f%%", 100 * moved);
                caustic_literal += (caustic_literal.empty() ? "" : ", ") + scene.name + " " +
                                   report::format("%.1f%%", 100 * dm_lit) + " -> " +
                                   report::format("%.1f%%", 100 * dm_def);
            }
        }

        auto coverage_row = [&](const Frame& f, const Descriptor& d, const std::string& what) {
            DescriptorSummary s = summarize(f, d);
            if (s.energy_share[gpu::BUCKET_OTHER] > worst_other) {
                worst_other = s.energy_share[gpu::BUCKET_OTHER];
                other_where = scene.name + " " + what;
            }
            cov.add({Cell::str(scene.name), Cell::str(what), Cell::num(s.energy_share[gpu::BUCKET_OTHER], "%.3g"),
                     Cell::num(s.max_bucket_sum_error, "%.2g"),
                     Cell::integer(static_cast<long long>(s.nonfinite_samples)),
                     Cell::integer(static_cast<long long>(s.labelled_pixels))});
        };
        for (size_t i = 0; i < nl; ++i)
            coverage_row(frames[i], desc[i], "nee " + std::to_string(cfg.stability_spp[i]) + " spp");
        coverage_row(mis_pilot, dmp, "mis-restricted " + pilot + " spp");
        coverage_row(mis_ref, dmr, "mis-restricted " + top + " spp");

        if (scene.name == "cubes_dof") {  // docs/descriptor.md §7: ~91% direct, the rest diffuse-indirect
            auto sh = stats::pixel_shares(ref, K);
            double heavy = sh[gpu::BUCKET_GLOSSY] + sh[gpu::BUCKET_DELTA_MEDIATED] + sh[gpu::BUCKET_SPECULAR_DIRECT];
            ctx.out.check(
                "cubes_dof is mostly direct with no heavy-tailed bucket", sh[gpu::BUCKET_DIRECT] > 0.8 && heavy == 0.0,
                report::format("%.1f%% direct", 100 * sh[gpu::BUCKET_DIRECT]) + ", " +
                    report::format("%.1f%% diffuse-indirect", 100 * sh[gpu::BUCKET_DIFFUSE_INDIRECT]) + ", " +
                    report::format("%.2f%% heavy", 100 * heavy) + " at " + top + " SPP (paper: 90.9% direct)");
        }
        for (size_t i = 0; i < nl; ++i) {
            auto sh = stats::pixel_shares(desc[i].dominant, K);
            std::vector<Cell> r{Cell::str(scene.name), Cell::integer(cfg.stability_spp[i])};
            for (double x : sh) r.push_back(Cell::pct(x));
            shares.add(r);
        }

        // Transition matrix pilot -> reference (rows: label at the pilot).
        Table tr{"transitions_" + scene_file_name(scene.name),
                 "Label transitions on " + scene.name + ": rows " + pilot + " SPP, columns " + top + " SPP (pixels)",
                 {"from \\ to"},
                 {},
                 ""};
        for (const char* b : kBucketNames) tr.columns.push_back(b);
        for (int i = 0; i < K; ++i) {
            std::vector<Cell> r{Cell::str(kBucketNames[i])};
            for (int j = 0; j < K; ++j) r.push_back(Cell::integer(static_cast<long long>(conf.at(i, j))));
            tr.add(r);
        }
        ctx.out.table(
            "Label transitions", tr,
            "diagonal = stable pixels; an off-diagonal cell counts pixels that moved from the row's bucket at the "
            "pilot to the column's bucket at the reference.");

        // Pictures: dominant maps at each level and the agreement map.
        std::string stem = scene_file_name(scene.name);
        const int fw = frames.front().width, fh = frames.front().height;
        const int s = std::max(1, 256 / fw);
        const std::vector<std::array<uint8_t, 3>> bucket_colors(kBucketColors.begin(), kBucketColors.end());
        const std::vector<std::string> bucket_names(kBucketNames.begin(), kBucketNames.end());
        for (size_t i = 0; i < nl; ++i) {
            int w = 0, h = 0;
            auto img = categorical_map_with_legend(fw * s, fh * s, enlarge(desc[i].dominant, fw, fh, s), bucket_colors,
                                                   bucket_names, "none (no energy)", &w, &h);
            ctx.out.image(
                "Dominant-class maps", "maps/" + stem + "_dominant_" + std::to_string(cfg.stability_spp[i]) + ".png", w,
                h, img,
                scene.name + " at " + std::to_string(cfg.stability_spp[i]) +
                    " SPP: each pixel coloured by the bucket carrying most of its energy (black: no energy).");
        }
        {
            int w = 0, h = 0;
            auto img = categorical_map_with_legend(
                fw * s, fh * s, enlarge(agreement_classes(pil, ref), fw, fh, s), {kAgreeGrey, kLightBlue, kStructRed},
                {"agree", "light-tailed swap", "structural swap"}, "unlabelled", &w, &h);
            ctx.out.image(
                "Agreement maps", "maps/" + stem + "_agreement.png", w, h, img,
                scene.name + ", " + pilot + " vs " + top +
                    " SPP: grey agrees, blue swaps inside {emitter-direct, direct, diffuse-indirect}, red swaps "
                    "to or from a structural bucket (as the paper's fig:cross-spp).");
        }

        {
            // The readings compared at the reference: which pixels change, and which of them are caustics on
            // diffuse surfaces (specular_direct under literal, delta_mediated under the default).
            std::vector<uint8_t> cls(ref.size(), kNoLabel);
            for (size_t q = 0; q < ref.size(); ++q) {
                if (ref[q] == kNoLabel || literal_ref[q] == kNoLabel) continue;
                cls[q] = ref[q] == literal_ref[q]                                                                  ? 0
                         : (literal_ref[q] == gpu::BUCKET_SPECULAR_DIRECT && ref[q] == gpu::BUCKET_DELTA_MEDIATED) ? 1
                                                                                                                   : 2;
            }
            int w = 0, h = 0;
            auto img = categorical_map_with_legend(fw * s, fh * s, enlarge(cls, fw, fh, s),
                                                   {kAgreeGrey, kBucketColors[gpu::BUCKET_DELTA_MEDIATED], kStructRed},
                                                   {"same label", "was specular_direct", "other change"}, "unlabelled",
                                                   &w, &h);
            ctx.out.image("End-vertex readings", "maps/" + stem + "_end_vertex.png", w, h, img,
                          scene.name + " at " + top +
                              " SPP, literal reading against the default (last non-delta): "
                              "magenta pixels (was specular_direct) are specular_direct under the literal reading and "
                              "delta_mediated under the "
                              "default (caustics seen on diffuse surfaces), red pixels change otherwise.");
            img = categorical_map_with_legend(fw * s, fh * s, enlarge(literal_ref, fw, fh, s), bucket_colors,
                                              bucket_names, "none (no energy)", &w, &h);
            ctx.out.image("End-vertex readings", "maps/" + stem + "_dominant_" + top + "_literal.png", w, h, img,
                          scene.name + " at " + top +
                              " SPP under `--end-vertex literal`: the dominant-class map to put "
                              "beside the default one above.");
        }

        // Per-bucket stability: of the reference's bucket-b pixels, the share the pilot (and MIS) also calls b.
        report::Panel p;
        p.kind = "bar";
        p.title = scene.name;
        p.ylabel = "share of reference pixels kept";
        p.ylim = std::make_pair(0.0, 1.05);
        p.hlines.push_back({0.95, "95%"});
        report::Series s_spp{"pilot " + pilot + " vs " + top, {}, {}, {}, {}, "#0072B2", "", "", 0, 0, {}};
        report::Series s_mis{"MIS vs NEE at " + top, {}, {}, {}, {}, "#D55E00", "", "", 0, 0, {}};
        for (int b = 0; b < K - 1; ++b) {
            p.categories.push_back(kBucketNames[b]);
            double n = 0, kept = 0, kept_mis = 0, n_mis = 0;
            for (size_t i = 0; i < ref.size(); ++i) {
                if (ref[i] != b) continue;
                if (pil[i] != kNoLabel) {
                    n += 1;
                    kept += pil[i] == b;
                }
                if (dmr.dominant[i] != kNoLabel) {
                    n_mis += 1;
                    kept_mis += dmr.dominant[i] == b;
                }
            }
            s_spp.y.push_back(n > 0 ? kept / n : NAN);
            s_mis.y.push_back(n_mis > 0 ? kept_mis / n_mis : NAN);
        }
        p.series = {s_spp, s_mis};
        bars.panels.push_back(p);
    }

    ctx.out.check("`other` receives 0% of the energy on every scene and render", worst_other == 0.0,
                  worst_other == 0.0 ? "0 in all " + std::to_string(cov.rows.size()) + " renders (coverage table)"
                                     : "largest share " + report::format("%.3g", worst_other) + " on " + other_where);
    ctx.out.check("the label's " + pilot + "-vs-" + top +
                      " agreement exceeds the 3-bin and 7-bin variance agreement on every scene",
                  label_vs_var_fail.empty(),
                  label_vs_var_fail.empty()
                      ? "on all " + std::to_string(cfg.scenes.size()) + " scenes (tab:discretized-sigma)"
                      : "not on: " + label_vs_var_fail);
    ctx.out.table(
        sec, cross,
        "higher is more stable; the paper reports 87-99.6% for 64 vs 4096 SPP on its versions of these scenes.");
    ctx.out.table(
        sec, kappa,
        "kappa removes the agreement a majority bucket gets by chance; weighted kappa above Cohen's means the "
        "residual flicker is mostly between light-tailed buckets.");
    ctx.out.table(sec, ev_pixels,
                  "which reading puts the caustics where the paper's scene descriptions do: under "
                  "last-nondelta a caustic on a diffuse surface is delta_mediated, under literal it is "
                  "specular_direct; the other buckets should barely move.");
    ctx.out.table(sec, ev_energy, "the same comparison by energy rather than by dominant pixels.");
    if (saw_caustic)
        ctx.out.check(
            "the default (last non-delta) end-vertex reading moves ring_caustic's and glass_caustic's caustics "
            "on diffuse surfaces from specular_direct to the delta_mediated population the paper's §4.1 "
            "describes (at least 0.5% of the pixels change that way)",
            caustic_default_ok,
            "pixels specular_direct under literal and delta_mediated under the default at " + top +
                " SPP: " + caustic_default + "; delta_mediated pixel share literal -> default: " + caustic_literal +
                " (tables/end_vertex_pixels.md)");
    ctx.out.table(sec, disc,
                  "the same agreement metric applied to the binned variance field: the label should agree far more "
                  "often than either binning (the last two columns are the ratios).");
    ctx.out.table(sec, mis,
                  "how much of the label survives restoring the suppressed BSDF-into-emitter half on the glossy and "
                  "delta-mediated buckets.");
    ctx.out.table(sec, shares, "bucket sizes per SPP level; the max drift column above is the largest change here.");
    ctx.out.table("Coverage", cov,
                  "`other` must be 0 everywhere and the buckets must sum to the luminance (closure ~1e-6).");
    ctx.out.figure(sec, bars,
                   "one panel per scene: for each bucket, the share of the reference's pixels that keep the label at "
                   "the pilot (blue) and under MIS (orange); the dashed line is 95%. Missing bars: empty bucket.");
}

}  // namespace vkmech
