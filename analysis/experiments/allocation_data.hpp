// The allocation study's per-scene data and its error measure, shared by the
// equal-sample tables (allocation.cpp) and the pool-resampling tables
// (allocation_pools.cpp): the reference, the pool, the pilot draws, and the
// errors of a final image drawn from a pool.
#pragma once

#include "allocation/allocation.hpp"
#include "experiments/allocation.hpp"

#include <array>
#include <map>
#include <vector>

namespace vkmech::allocation_data {

double lum_of(double r, double g, double b);

// Per-scene data the evaluations share.
struct SceneData {
    size_t P = 0;
    int w = 0, h = 0;
    std::vector<double> ref_rgb, ref_lum;  // unclamped linear RGB (docs/descriptor.md §6)
    std::vector<double> ref_rgb_clamped;   // clamped to [0, 1]: the display-range figures beside them
    double peak = 1.0;                     // the reference's largest RGB value: the PSNR peak
    // The firefly-robust companion (beside the headline, never instead): the
    // reference's 99.9th percentile of RGB values, and the reference clamped to it.
    double p999 = 1.0;
    std::vector<double> ref_rgb_p999;
    std::vector<uint8_t> ref_labels;
    std::vector<std::string> class_names;           // the labels' classes (AllocationSource::class_names), `other` last
    alloc::ClassTraits traits;                      // their heavy, constant and rare-tail classes
    SamplePool pool;                                // pool 0 (seed downstream_seeds::kPool)
    std::map<uint32_t, std::vector<Pilot>> pilots;  // N0 -> draws
    std::map<uint32_t, std::vector<alloc::PilotDiagnosis>> diagnoses;  // N0 -> the draws' diagnoses (§6.5)
};

// The strategy inputs of pilot draw k at N0 (the oracle from `pool`, the reference labels for the controls).
alloc::ScoreInputs pilot_inputs(const SceneData& d, const SamplePool& pool, uint32_t n0, uint32_t k);
inline alloc::ScoreInputs pilot_inputs(const SceneData& d, uint32_t n0, uint32_t k) {
    return pilot_inputs(d, d.pool, n0, k);
}

// Errors of one final image against the reference. Primary: unclamped linear
// RGB (MSE; relative MSE (x - r)^2 / (r^2 + 0.01); p99 of the absolute
// luminance error; per-bucket MSE). Beside them, never instead: the MSE on
// RGB clamped to [0, 1], which caps the heavy-tailed errors, and two
// firefly-robust companions: the median over pixels of the per-pixel squared
// error, and the MSE with both images clamped at the reference's 99.9th
// percentile.
struct Errors {
    double mse = 0, rel_mse = 0, p99 = 0, mse_clamped = 0;
    double median_se = 0, mse_p999 = 0;
    std::array<double, kBucketCount> bucket_mse{};
};

// The final image of an allocation: per pixel the mean of the first n(p) frames of `pool`.
Errors evaluate(const SceneData& d, const SamplePool& pool, const std::vector<uint32_t>& n);
inline Errors evaluate(const SceneData& d, const std::vector<uint32_t>& n) { return evaluate(d, d.pool, n); }

// Independent reference (docs/descriptor.md §4: chunks of seeds 900000 + c,
// merged), pool 0, then K disjoint pilot draws per N0 (median-of-means blocks
// where defined). Throws std::runtime_error when the pool or a pilot does not
// match the reference's film.
SceneData load_scene_data(AllocationSource& source, const StudyConfig& cfg, const SceneVariant& scene);
// Pool `index` of a scene, checked against the reference's film like pool 0.
SamplePool load_pool(AllocationSource& source, const SceneData& d, const SceneVariant& scene, uint32_t index);

}  // namespace vkmech::allocation_data
