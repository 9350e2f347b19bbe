// `vkmech study`: plans the renders of the requested studies (docs/descriptor.md §4 seed
// layouts), renders what the on-disk cache lacks with a progress line and
// SIGINT-safe resumption, then runs the experiments on cached frames and
// writes tables, figures, maps and report.md.
#pragma once

#include "io/interrupt.hpp"

#include "experiments/study_config.hpp"
#include "render/gpu_scene.hpp"
#include "render/taxonomy.hpp"
#include "scene/scene.hpp"

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace vkmech {

struct StudyOptions {
    std::string study;                                      // stability | variance | ... | all
    std::string preset = "quick";                           // quick | reduced | paper
    std::vector<std::string> scenes;                        // resolved scene files (the CLI resolves names)
    std::string sweep_roughness_scene, sweep_lights_scene;  // resolved sweep scene files
    std::optional<int> res;                                 // film width
    std::vector<uint32_t> spp_levels;                       // stability levels (last = reference)
    std::optional<int> seeds;                               // seeds per variance level (and per sweep level)
    std::optional<int> pools;                               // allocation: pools resampled (StudyConfig::alloc_pools)
    std::string out_dir;                                    // default out/study-<study>
    std::string cache_dir;                                  // default <out>/cache
    std::string curve;                                      // predictor: frozen curve for new scenes
    std::optional<uint32_t> device;
    std::optional<std::string> pipeline_cache;  // vk::ContextOptions::pipeline_cache_dir
    std::string kernel = "auto";                // vk::ContextOptions::kernel
    std::string traversal = "auto";
    bool no_plots = false;
    std::string plot_script;          // analysis/plot_figures.py as the CLI found it; empty: not found
    std::string plot_script_missing;  // then: where it was searched and how to say where it is
    bool plan_only = false;           // print the plan and the expected cost, render nothing
    bool equal_time = false;          // allocation: also compare strategies at equal wall-clock time
    // Scale-out (README "Studies on many machines"): the study's work units are
    // its planned renders, in plan order, then one unit per scene for the
    // allocation study's cached inputs. --shard i/N renders the units whose
    // index is i mod N and writes no table; --jobs FILE writes one command per
    // unit the cache lacks (each a --shard k/M of one unit) and renders
    // nothing; --analyse-only renders nothing the cache keeps and refuses,
    // listing them, when units are missing.
    std::optional<std::pair<uint32_t, uint32_t>> shard;  // (i, N), 0 <= i < N
    std::string shard_text;                              // the CLI's "i/N", parsed into `shard` by cmd_study
    std::string jobs_file;
    bool analyse_only = false;
    std::string command_line;          // for the report
    std::string display_server;        // host:port of a tev viewer: the renders in progress (render/live_view.hpp)
    std::string taxonomy;              // --taxonomy FILE (docs/lpe.md): every study by a user taxonomy's classes
    std::vector<std::string> defines;  // -D name=value: parameters of every --scenes scene
};

// Thrown when SIGINT or SIGTERM arrives during rendering: finished renders are cached.
class StudyInterrupted : public Interrupted {
public:
    using Interrupted::Interrupted;
};

// Returns the process exit code (0 ok; 1 when plotting failed).
int run_study(const StudyOptions& options);

// A scene variant loaded at a film width (the variant's own, where it has one)
// and flattened for a resolved traversal (flatten_scene), with the digest of
// its content.
struct LoadedScene {
    Scene scene;
    SceneArrays arrays;
    std::string digest;
};
// `taxonomy`: a user taxonomy's named shapes get materials of their own (render/taxonomy.hpp).
LoadedScene load_variant(const SceneVariant& v, int res, Traversal traversal,
                         const lpe::TaxonomySource* taxonomy = nullptr);
// A study --taxonomy compiled against a variant's labels (its warnings printed when asked); an error
// is bad input: std::invalid_argument naming the variant. taxonomy_key: what keys the renders that
// classify by it in the render cache (the digest of its words).
SceneTaxonomy compile_variant_taxonomy(const lpe::TaxonomySource& source, const SceneVariant& v, const Scene& scene,
                                       bool print_warnings);
std::string taxonomy_key(const SceneTaxonomy& t);

// The digest of the code that renders with traversal t (version and
// path-tracing SPIR-V): part of every render-cache key and of a sentinel record.
std::string render_code_digest(Traversal t, vk::KernelClass k);

// True once SIGINT arrived during a study (the handler is installed while rendering).
bool study_interrupted();

// The seven first-party scenes of docs/descriptor.md §7, in the paper's order.
const std::vector<std::string>& first_party_scenes();

}  // namespace vkmech
