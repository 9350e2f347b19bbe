// The CLI's commands: each registers its subcommand, options and action with main
// (register_*), and shares the helpers below.
#pragma once

#include "experiments/predictor.hpp"
#include "render/taxonomy.hpp"
#include "scene/scene.hpp"
#include "study/study_runner.hpp"
#include "vk/context.hpp"

#include <CLI/CLI.hpp>

#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace vkmech {

// Bad usage or bad input discovered after parsing: exit code 2.
class UsageError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct CommonOptions {
    std::string scene;                          // name in scenes/ or a path
    std::vector<std::string> defines;           // -D name=value
    std::optional<uint32_t> res;                // --res N: film width N, height by aspect
    std::optional<uint32_t> device;             // --device N
    std::string traversal = "auto";             // auto | rayquery | bvh
    bool substitute = false;                    // replace unsupported emitters (docs/descriptor.md §8)
    std::string environment;                    // --environment FILE: a lat-long map lights the scene
    float environment_scale = 1.0f;             // --environment-scale s
    bool environment_panel = false;             // --environment-panel: the paper's overhead panel (§8)
    size_t max_triangles = 0;                   // --max-triangles N (0: $VKMECH_MAX_TRIANGLES or the default)
    bool validation = false;                    // Vulkan validation layers
    std::optional<std::string> pipeline_cache;  // --pipeline-cache DIR|off (vk::ContextOptions)
    std::string kernel = "auto";                // --kernel auto|cpu|gpu (vk::KernelClass)
};

struct RenderOptions {
    CommonOptions common;
    uint32_t spp = 64;
    uint32_t seed = 0;
    uint32_t batch_spp = 8;
    std::string out_dir;
    std::string estimator;  // nee | mis-restricted | mis (docs/descriptor.md §1); empty: mis, nee with --adaptive
    std::string light_selection = "uniform";   // uniform | power (docs/descriptor.md §1)
    std::string end_vertex = "last-nondelta";  // last-nondelta | literal (docs/descriptor.md §2)
    float exposure = 0.0f;                     // PNG preview exposure in EV (stops)
    std::string capture = "on";                // on | off: the mechanism descriptor
    bool generic = false;                      // the unspecialized pipeline (for comparisons)
    bool preview = false;                      // provisional direct-light preview instead of the estimator
    // Optional outputs beyond the descriptor: direct_glossy (docs/descriptor.md §3.4).
    std::vector<std::string> extra_outputs;
    std::string taxonomy;  // --taxonomy FILE (docs/lpe.md): the classes replace the seven buckets (plain render)
    std::vector<std::string> lpe;  // --lpe name=EXPR (docs/lpe.md): overlapping query channels (plain render)
    // Two-stage adaptive rendering (docs/descriptor.md §6): strategy, pilot N0, extra budget, floor, pilot draw.
    std::string adaptive;
    uint32_t pilot = 16;
    uint32_t budget = 32;
    uint32_t floor = 1;
    uint32_t pilot_draw = 0;
    std::string curve;           // frozen predictor curve (default: docs/results/predictor_curve.json)
    std::string display_server;  // host:port of a tev viewer: the render in progress (io/display_client.hpp)
    std::string sample_range;    // "A:B": samples [A, B) of the seed (render only; not with --adaptive)
    std::string pixel_bounds;    // "x0,x1,y0,y1": a window of the film (render only; not with --adaptive)
    bool spp_given = false;      // --spp was on the command line
    bool batch_given = false;    // --batch was on the command line
    // render --noise-threshold T (docs/descriptor.md §6.8); 0: off.
    double noise_threshold = 0.0;
    uint32_t min_spp = 16, max_spp = 1024;
    double time_limit = 0.0;  // seconds; 0: none
    double spp_budget = 0.0;  // average samples per pixel in all; 0: none
    std::string noise_rule = "guarded";
};

// `vkmech sentinel register` (docs/descriptor.md §9).
struct SentinelOptions {
    CommonOptions common;
    uint32_t pilot = 64;      // N0: the frozen curve's pilot
    uint32_t pilot_draw = 0;  // pilot seed downstream_seeds::pilot(k)
    std::string out;          // the record (default sentinel_<scene>.json)
    std::string curve;        // frozen predictor curve (default: found as `vkmech paths` says)
    std::string name;         // the scene's name in the record (default: the file stem)
    std::string taxonomy;     // --taxonomy FILE (docs/lpe.md): the pilot labelled by its classes
    bool force = false;       // overwrite an existing record
    // The evaluation protocol, fixed in the record (docs/descriptor.md §9.4).
    uint32_t reference_spp = 2048, draws = 10, extra = 32, floor = 1;
};

// `vkmech sentinel evaluate`.
struct SentinelEvaluateOptions {
    std::string record;
    std::string out;    // default: <record without .json>_evaluation/
    std::string cache;  // default: <out>/cache
    std::optional<uint32_t> device;
    std::optional<std::string> pipeline_cache;
    std::string kernel = "auto";     // --kernel (vk::KernelClass)
    bool allow_code_change = false;  // evaluate with code other than the registered code
    bool force = false;              // overwrite an existing evaluation
};

struct BenchOptions {
    std::vector<std::string> scenes;
    uint32_t rays = 1u << 18;
    uint32_t res = 128;                       // bench render: film width
    uint32_t spp = 8;                         // bench render: samples per measurement
    bool profile = false;                     // bench render: where a render's time goes, per batch size
    std::vector<uint32_t> batches{1, 8, 64};  // bench render --profile: samples per dispatch tried
    std::optional<uint32_t> device;
    std::optional<std::string> pipeline_cache;
    std::string kernel = "auto";          // --kernel (vk::KernelClass)
    std::optional<std::string> dump_dir;  // bench traversal --dump DIR
    bool counters = false;                // bench traversal --counters: the software BVH's work per ray
    bool bvh_only = false;                // bench traversal --bvh-only: no ray-query measurement
    bool slices = false;                  // bench traversal --slices: the bvh column with slices on any device
    bool ablation = false;                // bench render --ablation: each effect the scene does not need, kept in alone
};

// `vkmech bench traversal` traces random_rays(arrays, rays, kBenchTraversalSeed)
// on every scene, so that its rays are the same from run to run.
inline constexpr uint32_t kBenchTraversalSeed = 1;

void add_common_options(CLI::App* app, CommonOptions& o);
// --pipeline-cache DIR|off (render, bench, study).
void add_pipeline_cache_option(CLI::App* app, std::optional<std::string>& dir);
// --kernel auto|cpu|gpu: the device-class kernel (vk::KernelClass).
void add_kernel_option(CLI::App* app, std::string& kernel);

// Finds scenes/NAME.xml for a bare name, else treats the argument as a path.
std::string resolve_scene_path(const std::string& name_or_path);
// All scene files in the project's scenes/ directory (sorted).
std::vector<std::string> project_scene_names();

// The device options of --device, --validation and --pipeline-cache.
vk::ContextOptions context_options(const CommonOptions& o);
// -D name=value pairs; throws UsageError on one without a name or '='.
std::map<std::string, std::string> parse_defines(const std::vector<std::string>& defines);
// The scene of --scene with -D, --res, --substitute and --max-triangles
// applied; its warnings and substitutions on stderr when `report`.
Scene load_for_cli(const CommonOptions& o, bool report = true);

// `--taxonomy FILE` and `--lpe name=EXPR` (repeatable; docs/lpe.md): read, and the shapes they name given
// materials of their own (before the scene goes to the device); then compiled against the scene on the device,
// the taxonomy as a partition and the queries as overlapping channels, warnings printed. Errors are usage errors
// (exit 2) naming file (or `--lpe`, the k-th option for line k), line and column.
lpe::TaxonomySource read_labels_for_cli(const std::function<lpe::TaxonomySource()>& read, Scene& scene);
SceneTaxonomy compile_labels_for_cli(const lpe::TaxonomySource& source, const Scene& scene, bool queries);
// "ring_caustic" for "ring_caustic" and for "path/to/ring_caustic.xml".
std::string scene_stem(const std::string& name_or_path);

// Usage errors (exit 2) before anything renders: `dir` (the value of `option`,
// e.g. --out) cannot be created or written; `path` is not a valid frozen
// reliability curve.
void require_writable_dir(const std::string& dir, const std::string& option);
void check_curve_for_cli(const std::string& path);
// A --curve, read (UsageError on a missing or malformed file) and refused (UsageError) unless it was fitted on the
// labels in use: `taxonomy_sha256`, the SHA-256 of the --taxonomy file, empty for the buckets.
ReliabilityCurve load_curve_for_cli(const std::string& path, const std::string& taxonomy_sha256 = "");
// The SHA-256 of a --taxonomy file; UsageError (exit 2) when it cannot be read.
std::string taxonomy_sha256_for_cli(const std::string& path);

// One `vkmech` subcommand and its action, which main runs once the command line is parsed;
// `args` is the command line after `vkmech` (a study records it). Each command file adds its
// own with a register_* function (docs/architecture.md, "A CLI command").
struct CliCommand {
    CLI::App* sub = nullptr;
    std::function<int(const std::vector<std::string>& args)> run;
};
using CliCommands = std::vector<CliCommand>;

void register_render(CLI::App& app, CliCommands& commands);    // render_command.cpp: render, render --adaptive
void register_devices(CLI::App& app, CliCommands& commands);   // bench_command.cpp: devices
void register_bench(CLI::App& app, CliCommands& commands);     // bench_command.cpp: bench traversal|render
void register_paths(CLI::App& app, CliCommands& commands);     // resources.cpp: paths
void register_check(CLI::App& app, CliCommands& commands);     // check_command.cpp: check
void register_merge(CLI::App& app, CliCommands& commands);     // merge_command.cpp: merge
void register_study(CLI::App& app, CliCommands& commands);     // study_command.cpp: study
void register_verify(CLI::App& app, CliCommands& commands);    // study_command.cpp: verify outputs|cache
void register_sentinel(CLI::App& app, CliCommands& commands);  // sentinel_command.cpp: sentinel ...

}  // namespace vkmech
