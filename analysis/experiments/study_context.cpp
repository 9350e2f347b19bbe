#include "experiments/study_context.hpp"
#include "allocation/adaptive_mom.hpp"

#include "io/png.hpp"
#include "stats/agreement.hpp"
#include "stats/quantiles.hpp"
#include "stats/summary.hpp"

#include <algorithm>
#include <filesystem>
#include <map>
#include <sstream>
#include <stdexcept>

namespace fs = std::filesystem;

namespace vkmech {

void StudyOutput::table(const std::string& section, const report::Table& t, const std::string& how) {
    std::string md = report::write_table((fs::path(dir_) / "tables").string(), t);
    entries_.push_back({section, "table", "tables/" + t.name + ".md", how, t.markdown()});
}

void StudyOutput::figure(const std::string& section, const report::Figure& f, const std::string& how) {
    report::write_figure((fs::path(dir_) / "figures").string(), f);
    entries_.push_back({section, "figure", "figures/" + f.name + ".png", how, ""});
}

void StudyOutput::image(const std::string& section, const std::string& rel, int w, int h,
                        const std::vector<uint8_t>& rgb, const std::string& how) {
    write_png_rgb8((fs::path(dir_) / rel).string(), w, h, rgb);
    entries_.push_back({section, "image", rel, how, ""});
}

void StudyOutput::text(const std::string& section, const std::string& md) {
    entries_.push_back({section, "text", "", "", md});
}

void StudyOutput::check(const std::string& claim, bool holds, const std::string& detail) {
    entries_.push_back({"Checks against the paper's shape", "check", "", "",
                        std::string("- **") + (holds ? "holds" : "differs") + "**: " + claim + " — " + detail});
}

std::vector<double> lum_mean_field(const Frame& f) {
    std::vector<double> v(f.pixels.size());
    for (size_t i = 0; i < v.size(); ++i) v[i] = f.pixels[i].lum_mean;
    return v;
}

std::vector<double> lum_var_field(const Frame& f) {
    std::vector<double> v(f.pixels.size());
    for (size_t i = 0; i < v.size(); ++i) v[i] = f.pixels[i].lum_var();
    return v;
}

std::vector<double> margin_field(const Frame& f) {
    std::vector<double> v(f.pixels.size(), 0.0);
    for (size_t i = 0; i < v.size(); ++i) {
        std::array<double, kBucketCount> e = f.pixels[i].bucket_sum;
        double sum = 0.0;
        for (double x : e) sum += x;
        if (sum <= 0.0) continue;
        std::sort(e.begin(), e.end(), std::greater<>());
        v[i] = (e[0] - e[1]) / sum;
    }
    return v;
}

std::vector<StudyClass> study_classes(const StudyConfig& cfg, const std::vector<uint32_t>& buckets) {
    std::vector<StudyClass> out;
    if (!cfg.taxonomy) {
        for (uint32_t b : buckets)
            out.push_back({b, kBucketNames[b], ((alloc::kRareTailBuckets >> b) & 1u) != 0,
                           ((gpu::HEAVY_BUCKETS >> b) & 1u) != 0});
        return out;
    }
    for (const lpe::TaxonomyLine& line : cfg.taxonomy->lines)
        out.push_back({static_cast<uint32_t>(out.size()), line.name, line.rare, line.heavy});
    out.push_back({static_cast<uint32_t>(out.size()), "other", false, false});
    return out;
}

HeavyClasses heavy_classes(const StudyConfig& cfg) {
    HeavyClasses h;
    std::vector<uint32_t> all(kBucketCount);
    for (uint32_t b = 0; b < kBucketCount; ++b) all[b] = b;
    std::string names;
    for (const StudyClass& c : study_classes(cfg, all)) {
        if (!c.heavy || c.slot >= kBucketCount) continue;
        h.slots.push_back(c.slot);
        if (cfg.taxonomy) names += (names.empty() ? "" : ", ") + c.name;
    }
    if (!cfg.taxonomy) return h;
    if (names.empty()) names = "none: the taxonomy declares no class [heavy]";
    h.declared = "the classes of the taxonomy " + cfg.taxonomy->file + " declared [heavy] (" + names + ")";
    return h;
}

std::string taxonomy_labels_lead(const StudyConfig& cfg) {
    return "Labels: the classes of the taxonomy `" + (cfg.taxonomy ? cfg.taxonomy->file : std::string()) +
           "` (docs/lpe.md)";
}

std::vector<double> bucket_field(const Frame& f, uint32_t b) {
    std::vector<double> v(f.pixels.size(), 0.0);
    for (size_t i = 0; i < v.size(); ++i)
        if (f.pixels[i].count > 0) v[i] = f.pixels[i].bucket_sum[b] / f.pixels[i].count;
    return v;
}

std::vector<double> intrinsic_variance(const std::vector<std::vector<double>>& m, const std::vector<int>& subset,
                                       double K) {
    const size_t P = m.front().size();
    std::vector<double> v(P);
    std::vector<double> x(subset.size());
    for (size_t p = 0; p < P; ++p) {
        for (size_t i = 0; i < subset.size(); ++i) x[i] = m[subset[i]][p];
        v[p] = K * stats::sample_variance(x);
    }
    return v;
}

std::vector<uint8_t> variance_bins(const std::vector<double>& var, const std::vector<uint8_t>& labels_a,
                                   const std::vector<uint8_t>& labels_b, int bins) {
    std::vector<double> vals;
    for (size_t i = 0; i < var.size(); ++i)
        if (labels_a[i] != stats::kNoLabel && labels_b[i] != stats::kNoLabel) vals.push_back(var[i]);
    std::vector<uint8_t> out(var.size(), 255);
    if (vals.empty()) return out;
    auto edges = stats::quantile_edges(vals, bins);  // docs/descriptor.md §5: edges per SPP level
    auto binned = stats::quantile_bin(vals, edges);
    for (size_t i = 0, j = 0; i < var.size(); ++i)
        if (labels_a[i] != stats::kNoLabel && labels_b[i] != stats::kNoLabel) out[i] = binned[j++];
    return out;
}

namespace {
// One entry per bucket: whether its bit is set in a gpu::*_BUCKETS mask.
std::vector<bool> bucket_family(uint32_t mask) {
    std::vector<bool> v(kBucketCount);
    for (uint32_t b = 0; b < kBucketCount; ++b) v[b] = ((mask >> b) & 1u) != 0;
    return v;
}
}  // namespace

const std::vector<bool>& light_tailed_buckets() {
    static const std::vector<bool> v = bucket_family(gpu::LIGHT_BUCKETS);
    return v;
}
const std::vector<bool>& heavy_buckets() {
    static const std::vector<bool> v = bucket_family(gpu::HEAVY_BUCKETS);
    return v;
}

StudyFn study_function(StudyKind k) {
    static const std::vector<std::pair<StudyKind, StudyFn>> kRunners = {
        {StudyKind::Stability, run_stability},
        {StudyKind::Variance, run_variance},
        {StudyKind::Cost, run_cost},
        {StudyKind::Structure, run_structure},
        {StudyKind::SweepRoughness, run_sweep_roughness},
        {StudyKind::SweepLights, run_sweep_lights},
        {StudyKind::Predictor, run_predictor},
        {StudyKind::Allocation, run_allocation},
        {StudyKind::Sensitivity, run_sensitivity}};
    for (const auto& [kind, fn] : kRunners)
        if (kind == k) return fn;
    throw std::logic_error(std::string("study: no runner for the study kind ") + to_string(k));
}

std::string build_report(const StudyOutput& out, const std::string& header) {
    std::ostringstream o;
    o << header << "\n";
    // Headline tables first, then pictures, then the long per-scene detail.
    std::vector<std::string> sections = {"Checks against the paper's shape",
                                         "Cross-SPP stability",
                                         "Coverage",
                                         "Dominant-class maps",
                                         "Agreement maps",
                                         "Variance baseline",
                                         "Time-to-quality",
                                         "Correlation structure",
                                         "Roughness sweep",
                                         "Light-count sweep",
                                         "Reliability predictor",
                                         "Label transitions"};
    for (const auto& e : out.entries())
        if (std::find(sections.begin(), sections.end(), e.section) == sections.end()) sections.push_back(e.section);
    std::erase_if(sections, [&](const std::string& s) {
        return std::none_of(out.entries().begin(), out.entries().end(), [&](const auto& e) { return e.section == s; });
    });
    o << "## Contents\n\n";
    for (const auto& s : sections) {
        std::string anchor;
        for (char c : s)
            anchor += std::isalnum(static_cast<unsigned char>(c)) ? static_cast<char>(std::tolower(c))
                                                                  : (c == ' ' || c == '-' ? '-' : '\0');
        anchor.erase(std::remove(anchor.begin(), anchor.end(), '\0'), anchor.end());
        o << "- [" << s << "](#" << anchor << ")\n";
    }
    o << "\n";
    for (const auto& s : sections) {
        o << "## " << s << "\n\n";
        for (const auto& e : out.entries()) {
            if (e.section != s) continue;
            if (e.kind == "check") {
                o << e.markdown << "\n";
            } else if (e.kind == "text") {
                o << e.markdown << "\n\n";
            } else if (e.kind == "table") {
                o << e.markdown << "\n";
                o << "*How to read:* " << e.how_to_read << " ([" << e.path << "](" << e.path << "), CSV beside it)\n\n";
            } else {
                o << "![" << e.path << "](" << e.path << ")\n\n";
                o << "*How to read:* " << e.how_to_read << " (`" << e.path << "`)\n\n";
            }
        }
        o << "\n";
    }
    return o.str();
}

}  // namespace vkmech
