// What a study renders and how (docs/descriptor.md §4 seed layouts, §5 analyses): scene
// variants, render requests, budgets and the presets (`--preset quick|
// reduced|paper`). Pure data; no Vulkan.
#pragma once

#include "render/features.hpp"
#include "render/lpe.hpp"

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

namespace vkmech {

// A scene file plus its -D parameters (the sweeps are one file, many variants).
struct SceneVariant {
    std::string name;  // display name: the file stem, plus "alpha=0.03" style suffixes
    std::string path;  // resolved scene file
    std::map<std::string, std::string> params;
    int res = 0;  // film width; 0: the study's
    bool operator<(const SceneVariant& o) const {
        return std::tie(path, params, res) < std::tie(o.path, o.params, o.res);
    }
    bool operator==(const SceneVariant& o) const { return path == o.path && params == o.params && res == o.res; }
};

// One render of the study: everything that determines it besides the code,
// the device and the film size (those are in the cache key too).
struct RenderRequest {
    SceneVariant scene;
    uint32_t spp = 0;
    uint32_t seed = 0;
    Estimator estimator = Estimator::Nee;
    EndVertex end_vertex = EndVertex::LastNonDelta;  // docs/descriptor.md §2 reading
    bool operator<(const RenderRequest& o) const {
        return std::tie(scene, spp, seed, estimator, end_vertex) <
               std::tie(o.scene, o.spp, o.seed, o.estimator, o.end_vertex);
    }
    bool operator==(const RenderRequest& o) const {
        return scene == o.scene && spp == o.spp && seed == o.seed && estimator == o.estimator &&
               end_vertex == o.end_vertex;
    }
};

enum class StudyKind {
    Stability,
    Variance,
    Cost,
    Structure,
    SweepRoughness,
    SweepLights,
    Predictor,
    Allocation,
    Sensitivity
};
const char* to_string(StudyKind k);
// "all" expands to the paper's analyses (every kind but Sensitivity, which goes
// beyond the paper and runs by name); throws std::invalid_argument naming the valid ones.
std::vector<StudyKind> parse_study(const std::string& name);

struct StudyConfig {
    std::string preset = "quick";
    std::vector<SceneVariant> scenes;  // the first-party set unless --scenes
    int res = 32;                      // film width (height by the scene's aspect)
    uint32_t batch_spp = 16;

    // Stability (docs/descriptor.md §5 agreement): ascending; the last level is the reference,
    // rendered with a seed disjoint from every lower level. The first level is
    // the pilot of the reliability predictor.
    std::vector<uint32_t> stability_spp{4, 16, 64};
    // Variance sweeps: `variance_seeds` seeds per level (docs/descriptor.md §4; 10 in the paper).
    std::vector<uint32_t> variance_spp{4, 8, 16, 32};
    int variance_seeds = 10;
    int split_half_partitions = 20;  // docs/descriptor.md §5: 20 random 5+5 partitions, base seed 0
    // Time-to-quality: independent renders per level; reference = the top stability render.
    std::vector<uint32_t> cost_spp{4, 8, 16, 32};
    double cost_tau = 0.10;
    // Sweeps (paper §5.4): per level `sweep_seeds` x `sweep_spp` plus a reference.
    std::vector<std::string> sweep_alphas{"0.01", "0.02", "0.03", "0.042", "0.06", "0.10", "0.18", "0.30"};
    std::vector<int> sweep_lights{1, 2, 4, 8, 16};
    uint32_t sweep_spp = 8;
    int sweep_seeds = 10;
    uint32_t sweep_ref_spp = 64;
    std::string sweep_roughness_scene, sweep_lights_scene;  // resolved paths
    std::string predictor_curve;                            // --curve: predict new scenes from their pilots only
    // --taxonomy FILE (docs/lpe.md; `study stability`, variance, cost, predictor, allocation, structure,
    // sensitivity): every
    // render classifies by it (the render cache keys each variant's renders by the compiled words); the
    // stability study measures its classes, and the allocation study's strategies read them and the
    // properties its lines declare ([heavy], [constant], [rare]).
    std::optional<lpe::TaxonomySource> taxonomy;
    std::string taxonomy_sha256;  // its file's SHA-256 (a predictor curve fitted on it records it)

    // Downstream allocation (docs/descriptor.md §6): pilots N0, K disjoint pilot draws, extra
    // budget (on top of the baseline 1), the budget sweep, the f = 4 control,
    // and an independent reference of alloc_ref_chunks x alloc_ref_chunk_spp.
    std::vector<uint32_t> alloc_pilots{4, 16, 64};
    int alloc_draws = 10;
    uint32_t alloc_extra = 32;
    std::vector<uint32_t> alloc_budget_sweep{32, 64, 128};
    std::vector<uint32_t> alloc_floors{1, 4};
    // The median-of-means block-count sweep (paper §7 Result 3): block counts k tried at
    // every pilot where median-of-means is defined (blocks of at least 2 samples).
    std::vector<int> alloc_mom_k{2, 3, 4, 6, 8};
    uint32_t alloc_ref_chunks = 2, alloc_ref_chunk_spp = 128;
    int alloc_res = 32;
    // Pools (issue 36): the tables at equal samples draw every final image from
    // pool 0; alloc_pools - 1 further pools of disjoint seeds resample it for
    // the spread over pool x pilot draws (tab alloc_pools, alloc_firefly).
    int alloc_pools = 2;
    bool equal_time = false;
    std::vector<uint32_t> equal_time_budgets{8, 16, 32, 64, 128};

    uint32_t stability_reference_spp() const { return stability_spp.back(); }
    uint32_t pilot_spp() const { return stability_spp.front(); }
    // Throws std::invalid_argument when a budget is unusable (explains why).
    // `needs_cost`: the time-to-quality study runs (its levels must stay below the reference).
    void validate(bool needs_cost = true) const;
    std::string describe() const;  // one paragraph for the report and the start line
};

// quick (CI: tiny images, low spp), reduced (what lavapipe affords for the
// committed docs/results run) and paper (docs/descriptor.md §4/§5 protocol, 256²).
// Throws std::invalid_argument for an unknown name.
StudyConfig preset_config(const std::string& name);

// docs/descriptor.md §4 seed layouts. Disjoint by construction: every family has its own
// range, and the levels within a family use distinct seeds.
namespace seeds {
uint32_t stability(size_t level);  // 100 + level
// The robustness comparison's second top-level renders (paper §4.4,
// tab:robust-mis), seed-disjoint from the NEE reference: the restricted-MIS
// render (150) and an NEE render (151) that gives the noise floor.
uint32_t mis_disjoint_reference();                // 150
uint32_t nee_disjoint_reference();                // 151
uint32_t variance(size_t level, int seed_index);  // 2000 + 100 * level + s
uint32_t cost(size_t level);                      // 3000 + level
uint32_t sweep(int seed_index);                   // 4000 + s
uint32_t sweep_reference();                       // 4999
uint32_t sensitivity(int seed_index);             // 6000 + s
}  // namespace seeds

// The sensitivity study (docs/results/sensitivity): controlled one-at-a-time
// variations of what makes a scene heavy-tailed. A level is a scene variant
// and the estimator it is rendered with; every axis passes through the scene
// as committed (its `base` level, the study's own scene variant).
struct SensitivityLevel {
    SceneVariant variant;
    Estimator estimator = Estimator::Nee;
    double x = 0.0;     // the level's value on the figure's axis
    std::string label;  // the level's name in the table
};
struct SensitivityAxis {
    std::string scene;  // the scene's display name
    std::string name, xlabel;
    bool logx = false;
    std::vector<SensitivityLevel> levels;
    size_t base = 0;  // index of the scene as committed
};
// The axes of every scene of cfg.scenes the study knows how to vary
// (glass_caustic, cubes_dof); other scenes have none.
std::vector<SensitivityAxis> sensitivity_axes(const StudyConfig& cfg);

// The renders each study needs (stable order, may repeat across studies).
std::vector<RenderRequest> plan_renders(const StudyConfig& cfg, StudyKind kind);
// Sweep variants of the roughness and light-count scenes.
std::vector<SceneVariant> roughness_variants(const StudyConfig& cfg);
std::vector<SceneVariant> light_variants(const StudyConfig& cfg);

}  // namespace vkmech
