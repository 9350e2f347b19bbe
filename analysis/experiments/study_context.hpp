// What an experiment sees: the configuration, a source of finished renders
// (from the cache; experiments never touch Vulkan except through the
// separation callback) and the output collector that becomes report.md.
#pragma once

#include "experiments/study_config.hpp"
#include "render/descriptor.hpp"
#include "render/frame.hpp"
#include "report/figure.hpp"
#include "report/table.hpp"

#include <algorithm>
#include <array>
#include <functional>
#include <string>
#include <vector>

namespace vkmech {

struct SeparationMeasures;
class AllocationSource;

class FrameSource {
public:
    virtual ~FrameSource() = default;
    virtual Frame get(const RenderRequest& r) = 0;
};

// Collects the study's outputs and their one-sentence reading guides.
class StudyOutput {
public:
    explicit StudyOutput(std::string dir) : dir_(std::move(dir)) {}
    struct Entry {
        std::string section, kind, path, how_to_read, markdown;  // kind: table | figure | image | text
    };
    const std::string& dir() const { return dir_; }
    void table(const std::string& section, const report::Table& t, const std::string& how_to_read);
    void figure(const std::string& section, const report::Figure& f, const std::string& how_to_read);
    void image(const std::string& section, const std::string& rel_path, int w, int h, const std::vector<uint8_t>& rgb,
               const std::string& how_to_read);
    void text(const std::string& section, const std::string& markdown);
    // A result whose shape the paper states (docs/descriptor.md §7): listed first in report.md as "holds" or "differs".
    void check(const std::string& claim, bool holds, const std::string& detail);
    const std::vector<Entry>& entries() const { return entries_; }

private:
    std::string dir_;
    std::vector<Entry> entries_;
};

struct StudyContext {
    const StudyConfig& cfg;
    FrameSource& frames;
    StudyOutput& out;
    std::string device;  // device name, for "ms on <device>"
    // Separation measures of a scene variant (needs the device); may be empty.
    std::function<SeparationMeasures(const SceneVariant&)> separation;
    // The allocation study's data (experiments/allocation.hpp); null where no study needs it.
    AllocationSource* allocation = nullptr;
};

// ---- the classes of a study's per-class tables ----
// A tally slot and its name: a bucket (docs/descriptor.md §2), or a class of --taxonomy's (docs/lpe.md).
struct StudyClass {
    uint32_t slot = 0;
    std::string name;
    bool rare = false;   // declared [rare] (a taxonomy's); the buckets': delta_mediated and specular_direct
    bool heavy = false;  // declared [heavy] (a taxonomy's); the buckets': glossy, delta_mediated, specular_direct
};
// Without --taxonomy, the listed buckets, in the list's order; with it, every class of the taxonomy,
// its lines' then `other`, in slot order (the study then reads each class as it reads a bucket).
std::vector<StudyClass> study_classes(const StudyConfig& cfg, const std::vector<uint32_t>& buckets);
// The opening of a report's note under --taxonomy: "Labels: the classes of the taxonomy `FILE` (docs/lpe.md)";
// each study goes on with what the classes mean for it.
std::string taxonomy_labels_lead(const StudyConfig& cfg);
// The heavy-tailed classes by slot: the buckets' (glossy, delta_mediated, specular_direct), or those a taxonomy
// declares [heavy]; under a taxonomy also the phrase naming them for a note ("none: ..." when it declares none).
struct HeavyClasses {
    std::vector<uint32_t> slots;
    std::string declared;  // under a taxonomy: "the classes of the taxonomy FILE declared [heavy] (names)"
    bool contains(uint32_t slot) const { return std::find(slots.begin(), slots.end(), slot) != slots.end(); }
};
HeavyClasses heavy_classes(const StudyConfig& cfg);

// ---- per-pixel fields shared by the experiments ----
std::vector<double> lum_mean_field(const Frame& f);
std::vector<double> lum_var_field(const Frame& f);  // ddof 1
// (L_top1 - L_top2) / sum_b L_b, 0 for unlabelled pixels (paper §8.2 "argmax margin").
std::vector<double> margin_field(const Frame& f);
// Mean per-sample energy of one bucket.
std::vector<double> bucket_field(const Frame& f, uint32_t bucket);
// sigma^2_intrinsic(p) = K * Var_s(m[s][p]) over the seeds of `subset` (ddof 1):
// the per-sample variance of a K-SPP render, estimated across seeds
// (docs/descriptor.md §5 split-half reliability).
std::vector<double> intrinsic_variance(const std::vector<std::vector<double>>& m, const std::vector<int>& subset,
                                       double K);
// The quantile-binned variance baseline (docs/descriptor.md §5): `var` binned
// into `bins` quantile bins over the pixels labelled in both label maps
// (edges per render); 255 elsewhere.
std::vector<uint8_t> variance_bins(const std::vector<double>& var, const std::vector<uint8_t>& labels_a,
                                   const std::vector<uint8_t>& labels_b, int bins);

// The light-tailed family {emitter-direct, direct, diffuse-indirect} and the
// heavy family {glossy, delta-mediated, specular-direct}: gpu::LIGHT_BUCKETS and
// gpu::HEAVY_BUCKETS as vectors (docs/descriptor.md §5 weights).
const std::vector<bool>& light_tailed_buckets();
const std::vector<bool>& heavy_buckets();

// One function per study (docs/descriptor.md §5); each computes a typed result
// and hands it to its writers (tables, figures, images, checks).
void run_stability(StudyContext& ctx);
// `study stability --taxonomy FILE`: the class-agnostic stability measures of a user taxonomy's
// classes (stability_taxonomy.cpp); run_stability calls it instead when StudyConfig::taxonomy is set.
void run_stability_taxonomy(StudyContext& ctx);
// The stability study's per-bucket, MIS-flip and sidefield tables (stability_sidefields.cpp); run_stability calls it.
void run_stability_sidefields(StudyContext& ctx);
void run_variance(StudyContext& ctx);
void run_cost(StudyContext& ctx);
void run_structure(StudyContext& ctx);
void run_sweep_roughness(StudyContext& ctx);
void run_sweep_lights(StudyContext& ctx);
void run_predictor(StudyContext& ctx);
void run_allocation(StudyContext& ctx);  // needs ctx.allocation
void run_sensitivity(StudyContext& ctx);

// The runner of a study kind.
using StudyFn = void (*)(StudyContext&);
StudyFn study_function(StudyKind k);

// report.md: every table inline, every figure and image linked, each with its
// reading guide, under `header` (command, preset, device, wall time).
std::string build_report(const StudyOutput& out, const std::string& header);

}  // namespace vkmech
