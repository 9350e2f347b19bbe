// `vkmech study allocation` (docs/descriptor.md §6, paper §7) as an
// experiment: per scene an independent reference, the shared pool of
// downstream_seeds::kPoolSize frames (one per sample index of the pool seed,
// so any n(p) is a prefix mean) and K disjoint pilot draws per N0; every
// strategy's allocation is scored against the reference, and each
// strategy's wall time (pilot + allocation + a real render of its n(p)) is
// reported. Where the data comes from is the AllocationSource's business:
// the app layer renders it on the GPU and keeps it in the render cache
// (host/app/study/allocation_source.hpp); a test can hand in synthetic data.
#pragma once

#include "allocation/floor.hpp"
#include "allocation/plan.hpp"
#include "experiments/study_context.hpp"

#include <memory>
#include <string>
#include <vector>

namespace vkmech {

class AllocationSource {
public:
    virtual ~AllocationSource() = default;
    // The independent reference of a scene variant (docs/descriptor.md §4: chunks
    // of seeds 900000 + c, merged) at the study's allocation resolution.
    virtual Frame reference(const SceneVariant& v) = 0;
    // Pool `index` (seed downstream_seeds::pool(index): 1000 + index, kPoolSize
    // frames) and its converged variance. Pool 0 is the pool every table at
    // equal samples draws from; the others resample it (cfg.alloc_pools).
    virtual SamplePool pool(const SceneVariant& v, uint32_t index) = 0;
    // Pilot draw `draw` (seed 100000 + 1000 draw) of n0 samples; with the
    // median-of-means variance where it is defined for n0.
    virtual Pilot pilot(const SceneVariant& v, uint32_t n0, uint32_t draw) = 0;
    // The same pilot draw's samples one by one, for the median-of-means
    // block-count sweep (asked only where median-of-means is defined).
    virtual PilotSamples pilot_samples(const SceneVariant& v, uint32_t n0, uint32_t draw) = 0;
    // Seconds of a real render of n(p) samples per pixel of the pool seed.
    virtual double final_render_seconds(const SceneVariant& v, const std::vector<uint32_t>& n) = 0;
    // The label classes of the frames and pilots: their names (`other` last) and what the strategies
    // read of them. The paper's buckets unless a study --taxonomy classifies the renders.
    virtual std::vector<std::string> class_names(const SceneVariant&) {
        return {kBucketNames.begin(), kBucketNames.end()};
    }
    virtual alloc::ClassTraits class_traits(const SceneVariant&) { return {}; }
};

// The strategies whose wall time run_allocation (study_context.hpp) measures at pilot n0 (one
// final render each, tab alloc_time), and those of its equal-time table at n0
// (one final render per equal-time budget each): at the smallest pilot the
// plain-variance ones, where median-of-means is defined the robust ones.
std::vector<alloc::Strategy> allocation_timed_strategies(uint32_t n0);
std::vector<alloc::Strategy> allocation_equal_time_strategies(uint32_t n0);

namespace allocation_data {
struct SceneData;
}

// The allocation study's pool resampling (allocation_pools.cpp): the main
// configurations scored on cfg.alloc_pools pools (nothing below two), with
// firefly-robust companions. run_allocation adds each scene from the data it
// loaded for its own tables (loaded once), then writes these tables after its own.
class AllocationPools {
public:
    explicit AllocationPools(const StudyConfig& cfg);
    ~AllocationPools();
    void add_scene(AllocationSource& source, const SceneVariant& scene, const allocation_data::SceneData& d);
    void write(StudyOutput& out) const;

private:
    struct Tables;
    const StudyConfig& cfg_;
    std::unique_ptr<Tables> t_;
};

// Paths per pixel the allocation study traces for one scene (reference, pool,
// pilots, timing renders), for the study's cost estimate.
double allocation_paths_per_pixel(const StudyConfig& cfg);

}  // namespace vkmech
