#include "experiments/predictor.hpp"

#include "experiments/study_context.hpp"
#include "io/atomic_file.hpp"
#include "io/json_value.hpp"
#include "stats/binning.hpp"
#include "stats/isotonic.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace vkmech {

using report::Cell;
using report::Table;

namespace {

int bin_of(double x, int bins) { return std::clamp(static_cast<int>(x * bins), 0, bins - 1); }

// The numbers of the array under "key"; throws std::runtime_error with the reason alone.
std::vector<double> parse_array(const std::string& text, const std::string& key) {
    auto k = text.find("\"" + key + "\"");
    if (k == std::string::npos) throw std::runtime_error("no \"" + key + "\" entry");
    auto open = text.find('[', k), close = text.find(']', k);
    if (open == std::string::npos || close == std::string::npos || close < open)
        throw std::runtime_error("\"" + key + "\" is not an array");
    std::vector<double> v;
    std::stringstream ss(text.substr(open + 1, close - open - 1));
    std::string item;
    while (std::getline(ss, item, ',')) {
        size_t used = 0;
        double x = NAN;
        try {
            x = std::stod(item, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used == 0 || item.find_first_not_of(" \t\r\n", used) != std::string::npos)
            throw std::runtime_error("bad number '" + item + "' in \"" + key + "\"");
        if (!(x >= 0.0 && x <= 1.0))
            throw std::runtime_error("\"" + key + "\" holds " + item + ", outside the reliability range [0, 1]");
        v.push_back(x);
    }
    return v;
}

struct PilotPixels {
    std::vector<double> margin, purity;
    std::vector<uint8_t> agree;  // empty without a reference
};

PilotPixels pilot_pixels(const Frame& pilot, const Frame* ref) {
    Descriptor dp = derive_descriptor(pilot);
    std::vector<uint8_t> ref_labels;
    if (ref) ref_labels = derive_descriptor(*ref).dominant;
    auto margin = margin_field(pilot);
    PilotPixels out;
    for (size_t p = 0; p < dp.dominant.size(); ++p) {
        if (dp.dominant[p] == kNoLabel) continue;
        if (ref && ref_labels[p] == kNoLabel) continue;  // docs/descriptor.md §5 agreement: labelled in both
        out.margin.push_back(margin[p]);
        out.purity.push_back(dp.purity[p]);
        if (ref) out.agree.push_back(dp.dominant[p] == ref_labels[p]);
    }
    return out;
}

// Pooled counts over the given scenes -> isotonic curve (empty bins weight 0).
std::vector<double> pooled_curve(const std::vector<stats::BinnedRate>& per_scene, const std::vector<size_t>& use,
                                 int bins) {
    std::vector<double> rate(bins, 0.0), w(bins, 0.0);
    for (int b = 0; b < bins; ++b) {
        double n = 0, h = 0;
        for (size_t s : use) {
            n += per_scene[s].count[b];
            h += per_scene[s].hits[b];
        }
        w[b] = n;
        rate[b] = n > 0 ? h / n : 0.0;
    }
    return stats::isotonic_increasing(rate, w);
}

}  // namespace

PilotPrediction predict_from_pilot(const ReliabilityCurve& curve, const Frame& pilot) {
    auto px = pilot_pixels(pilot, nullptr);
    return {ReliabilityCurve::predict(curve.margin, px.margin), ReliabilityCurve::predict(curve.purity, px.purity),
            px.margin.size()};
}

double ReliabilityCurve::predict(const std::vector<double>& curve, const std::vector<double>& x) {
    if (x.empty() || curve.empty()) return NAN;
    double s = 0;
    for (double v : x) s += curve[bin_of(v, static_cast<int>(curve.size()))];
    return s / x.size();
}

std::string ReliabilityCurve::json() const {
    std::ostringstream o;
    o.precision(9);
    o << "{\n  \"what\": \"vkmech label-reliability curve: agreement of the pilot's dominant label with the reference "
         "per "
         "equal-width bin on [0,1] of the pilot's argmax margin and purity (pooled, isotonic)\",\n";
    o << "  \"pilot_spp\": " << pilot_spp << ",\n  \"reference_spp\": " << reference_spp << ",\n  \"bins\": " << bins
      << ",\n";
    auto arr = [&](const std::vector<double>& v) {
        o << "[";
        for (size_t i = 0; i < v.size(); ++i) o << (i ? ", " : "") << v[i];
        o << "]";
    };
    o << "  \"margin\": ";
    arr(margin);
    o << ",\n  \"purity\": ";
    arr(purity);
    o << ",\n  \"scenes\": [";
    for (size_t i = 0; i < scenes.size(); ++i) o << (i ? ", " : "") << "\"" << json_escape(scenes[i]) << "\"";
    o << "]";
    if (!taxonomy_sha256.empty())
        o << ",\n  \"taxonomy\": {\"file\": \"" << json_escape(taxonomy_file) << "\", \"sha256\": \""
          << json_escape(taxonomy_sha256) << "\"}";
    o << "\n}\n";
    return o.str();
}

ReliabilityCurve ReliabilityCurve::load(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot read predictor curve '" + path + "'");
    std::stringstream ss;
    ss << in.rdbuf();
    std::string text = ss.str();
    ReliabilityCurve c;
    try {
        if (text.find_first_not_of(" \t\r\n") == std::string::npos) throw std::runtime_error("the file is empty");
        if (text.find("vkmech label-reliability curve") == std::string::npos)
            throw std::runtime_error(
                "it lacks the \"what\": \"vkmech label-reliability curve ...\" header that "
                "`vkmech study predictor` writes");
        c.margin = parse_array(text, "margin");
        c.purity = parse_array(text, "purity");
        if (c.margin.empty() || c.margin.size() != c.purity.size())
            throw std::runtime_error("margin and purity must be non-empty and of equal length");
        c.bins = static_cast<int>(c.margin.size());
        auto num = [&](const std::string& key) -> unsigned {
            auto k = text.find("\"" + key + "\"");
            if (k == std::string::npos) return 0;
            const char* p = text.c_str() + text.find(':', k) + 1;
            char* end = nullptr;
            unsigned long v = std::strtoul(p, &end, 10);
            if (end == p || v > (1ul << 31)) throw std::runtime_error("\"" + key + "\" is not a sample count");
            return static_cast<unsigned>(v);
        };
        c.pilot_spp = num("pilot_spp");
        c.reference_spp = num("reference_spp");
        if (text.find("\"taxonomy\"") != std::string::npos) {  // perhaps fitted on a taxonomy's classes
            std::string why;
            const std::optional<JsonValue> doc = parse_json(text, &why);
            if (!doc || doc->kind != JsonValue::Object) throw std::runtime_error("malformed JSON: " + why);
            const JsonValue* t = doc->find("taxonomy");  // the top-level member (a scene may be named so)
            if (!t) return c;
            const JsonValue* sha = t->kind == JsonValue::Object ? t->find("sha256") : nullptr;
            const JsonValue* file = t->kind == JsonValue::Object ? t->find("file") : nullptr;
            if (!sha || sha->kind != JsonValue::String || sha->string.empty() || !file ||
                file->kind != JsonValue::String)
                throw std::runtime_error("its \"taxonomy\" is not {\"file\": ..., \"sha256\": ...}");
            c.taxonomy_file = file->string;
            c.taxonomy_sha256 = sha->string;
        }
    } catch (const std::runtime_error& e) {
        throw std::runtime_error("'" + path + "' is not a valid reliability curve: " + e.what());
    }
    return c;
}

std::string curve_label_mismatch(const ReliabilityCurve& curve, const std::string& curve_file,
                                 const std::string& taxonomy_sha256) {
    if (curve.taxonomy_sha256 == taxonomy_sha256) return "";
    const std::string c = "the reliability curve '" + curve_file + "' was fitted on ";
    if (curve.taxonomy_sha256.empty())
        return c +
               "the paper's buckets, not on a taxonomy's classes (fit one with `vkmech study predictor --taxonomy "
               "FILE`, docs/lpe.md)";
    return c + "the classes of the taxonomy " + curve.taxonomy_file + " (SHA-256 " +
           curve.taxonomy_sha256.substr(0, 16) + "...), " +
           (taxonomy_sha256.empty() ? std::string("not on the paper's buckets")
                                    : "not on this taxonomy (SHA-256 " + taxonomy_sha256.substr(0, 16) + "...)");
}

namespace {

constexpr int kPredictorBins = 20;

// ---- new scenes: predicted agreement from their own pilot and a frozen curve ----

struct NewScenePrediction {
    std::string name;
    PilotPrediction prediction;
};

void run_predictor_new_scenes(StudyContext& ctx) {
    const StudyConfig& cfg = ctx.cfg;
    const ReliabilityCurve curve = ReliabilityCurve::load(cfg.predictor_curve);
    std::vector<NewScenePrediction> predictions;
    for (const auto& scene : cfg.scenes)
        predictions.push_back(
            {scene.name,
             predict_from_pilot(curve, ctx.frames.get({scene, cfg.pilot_spp(), seeds::stability(0), Estimator::Nee}))});

    Table t{"predictor_new",
            "Predicted label reliability from the pilot alone",
            {"scene", "pilot SPP", "labelled px", "pred. (margin)", "pred. (purity)"},
            {},
            ""};
    t.note = "Curve: " + cfg.predictor_curve + " (pilot " + std::to_string(curve.pilot_spp) + " SPP, reference " +
             std::to_string(curve.reference_spp) +
             " SPP). The prediction is the expected share of pixels whose pilot "
             "label matches a reference render.";
    if (curve.pilot_spp != 0 && curve.pilot_spp != cfg.pilot_spp())
        t.note += " Warning: this pilot has " + std::to_string(cfg.pilot_spp()) + " SPP, the curve was fitted on " +
                  std::to_string(curve.pilot_spp) + "-SPP pilots.";
    for (const NewScenePrediction& p : predictions)
        t.add({Cell::str(p.name), Cell::integer(cfg.pilot_spp()),
               Cell::integer(static_cast<long long>(p.prediction.labelled)), Cell::num(p.prediction.margin),
               Cell::num(p.prediction.purity)});
    ctx.out.table("Reliability predictor", t,
                  "the share of pixels expected to keep their pilot label at the reference budget.");
}

// ---- the study's scenes: the pooled curve and each scene's leave-one-scene-out prediction ----

struct PredictorScene {
    std::string name;
    size_t labelled = 0;
    double actual = NAN, pred_margin = NAN, pred_purity = NAN;  // agreement: actual and predicted
    stats::BinnedRate by_margin, by_purity;                     // agreement rate per pilot bin
};

struct PredictorResult {
    ReliabilityCurve curve;  // fitted on every scene
    std::vector<PredictorScene> scenes;
};

// Largest decrease between consecutive bins holding at least 20 pixels (monotonicity check).
double largest_drop(const stats::BinnedRate& r) {
    double drop = 0, prev = NAN;
    for (size_t b = 0; b < r.rate.size(); ++b) {
        if (r.count[b] < 20) continue;
        if (std::isfinite(prev)) drop = std::max(drop, prev - r.rate[b]);
        prev = r.rate[b];
    }
    return drop;
}

PredictorResult compute_predictor(StudyContext& ctx) {
    const StudyConfig& cfg = ctx.cfg;
    const int bins = kPredictorBins;
    PredictorResult r;
    std::vector<PilotPixels> px;
    std::vector<stats::BinnedRate> by_margin, by_purity;
    for (const auto& scene : cfg.scenes) {
        Frame p = ctx.frames.get({scene, cfg.pilot_spp(), seeds::stability(0), Estimator::Nee});
        Frame ref = ctx.frames.get(
            {scene, cfg.stability_reference_spp(), seeds::stability(cfg.stability_spp.size() - 1), Estimator::Nee});
        px.push_back(pilot_pixels(p, &ref));
        by_margin.push_back(stats::binned_rate(px.back().margin, px.back().agree, bins, 0.0, 1.0));
        by_purity.push_back(stats::binned_rate(px.back().purity, px.back().agree, bins, 0.0, 1.0));
    }
    std::vector<size_t> all(cfg.scenes.size());
    for (size_t i = 0; i < all.size(); ++i) all[i] = i;
    r.curve.bins = bins;
    r.curve.margin = pooled_curve(by_margin, all, bins);
    r.curve.purity = pooled_curve(by_purity, all, bins);
    if (cfg.taxonomy) {
        r.curve.taxonomy_file = cfg.taxonomy->file;
        r.curve.taxonomy_sha256 = cfg.taxonomy_sha256;
    }
    r.curve.pilot_spp = cfg.pilot_spp();
    r.curve.reference_spp = cfg.stability_reference_spp();
    for (const auto& s : cfg.scenes) r.curve.scenes.push_back(s.name);
    for (size_t s = 0; s < cfg.scenes.size(); ++s) {
        PredictorScene sc{cfg.scenes[s].name, px[s].agree.size(), NAN, NAN, NAN, by_margin[s], by_purity[s]};
        std::vector<size_t> others;
        for (size_t o : all)
            if (o != s) others.push_back(o);
        double actual = 0;
        for (uint8_t a : px[s].agree) actual += a;
        sc.actual = px[s].agree.empty() ? NAN : actual / px[s].agree.size();
        if (!others.empty()) {
            sc.pred_margin = ReliabilityCurve::predict(pooled_curve(by_margin, others, bins), px[s].margin);
            sc.pred_purity = ReliabilityCurve::predict(pooled_curve(by_purity, others, bins), px[s].purity);
        }
        r.scenes.push_back(std::move(sc));
    }
    return r;
}

// The three panels: agreement per margin bin, per purity bin, and predicted against actual.
report::Figure predictor_figure(const PredictorResult& r) {
    const int bins = kPredictorBins;
    report::Panel pm, pp, pa;
    pm.title = "agreement per pilot margin bin";
    pm.xlabel = "pilot argmax margin";
    pp.title = "agreement per pilot purity bin";
    pp.xlabel = "pilot purity";
    pm.ylabel = pp.ylabel = "agreement with the reference";
    pa.kind = "scatter";
    pa.title = "leave-one-scene-out: predicted vs actual";
    pa.xlabel = "actual agreement";
    pa.ylabel = "predicted agreement";
    pa.diagonal = true;
    report::Series sa_m{"margin curve", {}, {}, {}, {}, "#D55E00", "o", "", 6, 0, {}};
    report::Series sa_p{"purity curve", {}, {}, {}, {}, "#0072B2", "s", "", 6, 0, {}};
    std::vector<double> centres(bins);
    for (int b = 0; b < bins; ++b) centres[b] = (b + 0.5) / bins;
    for (const PredictorScene& sc : r.scenes) {
        sa_m.x.push_back(sc.actual);
        sa_m.y.push_back(sc.pred_margin);
        sa_p.x.push_back(sc.actual);
        sa_p.y.push_back(sc.pred_purity);
        auto thin = [&](const stats::BinnedRate& rate) {
            report::Series sr{sc.name, {}, {}, {}, {}, "", "", "-", 0, 0.6, {}};
            for (int b = 0; b < bins; ++b)
                if (rate.count[b] >= 10) {
                    sr.x.push_back(centres[b]);
                    sr.y.push_back(rate.rate[b]);
                }
            return sr;
        };
        pm.series.push_back(thin(sc.by_margin));
        pp.series.push_back(thin(sc.by_purity));
    }
    pm.series.push_back({"pooled isotonic", centres, r.curve.margin, {}, {}, "#000000", "", "-", 0, 0, {}});
    pp.series.push_back({"pooled isotonic", centres, r.curve.purity, {}, {}, "#000000", "", "-", 0, 0, {}});
    pa.series = {sa_m, sa_p};
    return {"predictor", "Label-reliability predictor", "", 3, {pm, pp, pa}};
}

Table predictor_table(const StudyConfig& cfg, const PredictorResult& r) {
    const std::string pilot = std::to_string(cfg.pilot_spp()), top = std::to_string(cfg.stability_reference_spp());
    Table t{"predictor",
            "Scene-level label reliability predicted from the pilot (leave-one-scene-out)",
            {"scene", "labelled px", "actual " + pilot + " vs " + top, "pred. (margin)", "error", "pred. (purity)",
             "error", "largest drop (margin)", "largest drop (purity)"},
            {},
            ""};
    double max_err_m = 0, max_err_p = 0;
    for (const PredictorScene& sc : r.scenes) {
        if (std::isfinite(sc.pred_margin)) max_err_m = std::max(max_err_m, std::fabs(sc.pred_margin - sc.actual));
        if (std::isfinite(sc.pred_purity)) max_err_p = std::max(max_err_p, std::fabs(sc.pred_purity - sc.actual));
        t.add({Cell::str(sc.name), Cell::integer(static_cast<long long>(sc.labelled)), Cell::num(sc.actual),
               Cell::num(sc.pred_margin), Cell::num(sc.pred_margin - sc.actual, "%+.3f"), Cell::num(sc.pred_purity),
               Cell::num(sc.pred_purity - sc.actual, "%+.3f"), Cell::num(largest_drop(sc.by_margin), "%.3f"),
               Cell::num(largest_drop(sc.by_purity), "%.3f")});
    }
    t.note =
        "Pilot " + pilot + " SPP, reference " + top +
        " SPP. Each scene's prediction uses the curve pooled over the "
        "other scenes (20 equal-width bins, isotonic); error = predicted - actual. Largest LOSO error: " +
        report::format("%.3f", max_err_m) + " (margin), " + report::format("%.3f", max_err_p) +
        " (purity). \"largest drop\": the largest decrease of the agreement rate between consecutive bins with >= 20 "
        "pixels (0 = monotone). The curve fitted on all scenes is frozen in predictor_curve.json (use it with "
        "`vkmech study predictor --curve FILE --scenes NEW` to predict a new scene from its pilot).";
    return t;
}

void write_predictor(StudyOutput& out, const StudyConfig& cfg, const PredictorResult& r) {
    const std::string sec = "Reliability predictor";
    write_file_atomic((std::filesystem::path(out.dir()) / "predictor_curve.json").string(), r.curve.json());
    if (cfg.taxonomy)
        out.text(sec, taxonomy_labels_lead(cfg) +
                          "; predictor_curve.json records it, and only renders and sentinels labelled "
                          "by the same file (by SHA-256) take the curve.");
    out.table(sec, predictor_table(cfg, r),
              "how well a scene's own pilot predicts its pilot-vs-reference agreement before any reference "
              "exists (the paper reports LOSO errors of at most 0.061 purity, 0.079 margin).");
    out.figure(sec, predictor_figure(r),
               "left and middle: agreement rate per pilot bin, one thin line per scene and the pooled monotone "
               "curve in black; right: leave-one-scene-out prediction against the actual agreement (diagonal = "
               "perfect).");
}

}  // namespace

void run_predictor(StudyContext& ctx) {
    if (!ctx.cfg.predictor_curve.empty()) {
        run_predictor_new_scenes(ctx);
        return;
    }
    write_predictor(ctx.out, ctx.cfg, compute_predictor(ctx));
}

}  // namespace vkmech
