// The allocation strategies of the downstream experiment (docs/descriptor.md §6, paper §7)
// and the score D(p) each one hands to the Neyman allocator (neyman.hpp).
#pragma once

#include "allocation/adaptive_mom.hpp"
#include "shared/types.h"

#include <cstdint>
#include <string>
#include <vector>

namespace vkmech::alloc {

enum class Strategy {
    Uniform,         // "uniform": D = 1 everywhere
    ObservedVar,     // "observed-var": D = pilot sigma^2 (the incumbent)
    Oracle,          // "oracle": D = the pool's converged variance (upper bound)
    BucketFloor,     // "bucket-floor": bucket_floor(pilot sigma^2, pilot labels)
    Placebo,         // "placebo": bucket_floor(pilot sigma^2, shuffled pilot labels)
    LabelOracle,     // "label-oracle": bucket_floor(pilot sigma^2, reference labels)
    RobustVar,       // "robust-var": D = median-of-means pilot variance (mom.hpp)
    RobustFloor,     // "robust-floor": bucket_floor(MoM variance, pilot labels)
    RobustPlacebo,   // "robust-placebo": bucket_floor(MoM variance, shuffled pilot labels)
    Guarded,         // "guarded": bucket-floor, at least the uniform share on untrusted pixels (guard.hpp)
    Shrink,          // "shrink": the pilot variance shrunk towards its label's prior (shrink.hpp)
    RobustAdaptive,  // "robust-adaptive": the MoM block count chosen per pixel from its pilot label (adaptive_mom.hpp)
    ShrinkGlobal,    // "shrink-global": shrink's placebo, every labelled pixel in one population (no label)
};

// Every strategy, in declaration order.
inline constexpr Strategy kAllStrategies[] = {
    Strategy::Uniform,     Strategy::ObservedVar,    Strategy::Oracle,       Strategy::BucketFloor,   Strategy::Placebo,
    Strategy::LabelOracle, Strategy::RobustVar,      Strategy::RobustFloor,  Strategy::RobustPlacebo, Strategy::Guarded,
    Strategy::Shrink,      Strategy::RobustAdaptive, Strategy::ShrinkGlobal,
};

// The command-line / report name ("uniform", "observed-var", ...).
const char* to_string(Strategy s);

// Inverse of to_string. Throws std::invalid_argument listing the valid names.
Strategy parse_strategy(const std::string& name);

// True for the strategies that need the median-of-means variance (n/a at
// N0 = 4, see mom.hpp).
bool needs_mom(Strategy s);

// Inputs of strategy_score, all per pixel and of one size; a strategy reads
// only the ones it needs, the others may be null.
struct ScoreInputs {
    const std::vector<double>* pilot_var = nullptr;          // pilot sigma^2 (ddof 1)
    const std::vector<uint8_t>* pilot_labels = nullptr;      // dominant bucket of the pilot
    const std::vector<double>* oracle_var = nullptr;         // converged variance of the pool
    const std::vector<uint8_t>* reference_labels = nullptr;  // dominant bucket of the reference
    const std::vector<double>* mom_var = nullptr;            // median-of-means pilot variance
    const std::vector<uint8_t>* untrusted = nullptr;         // PilotDiagnosis::untrusted_map (guard.hpp)
    uint32_t pilot_spp = 0;                                  // N0, for shrink's noise model (0: not given)
    uint32_t heavy = gpu::HEAVY_BUCKETS;  // the floor's heavy-tailed classes (ClassTraits::heavy, floor.hpp)
    uint32_t rare = kRareTailBuckets;     // robust-adaptive's rare-tail classes (ClassTraits::rare)
};

// The score D(p) of strategy s:
//   Uniform       -> all ones (pixel count from the first non-null input)
//   ObservedVar   -> *pilot_var
//   Oracle        -> *oracle_var
//   BucketFloor   -> bucket_floor(*pilot_var, *pilot_labels)
//   Placebo       -> bucket_floor(*pilot_var, placebo_labels(*pilot_labels, placebo_seed))
//   LabelOracle   -> bucket_floor(*pilot_var, *reference_labels)
//   RobustVar     -> *mom_var
//   RobustFloor   -> bucket_floor(*mom_var, *pilot_labels)
//   RobustPlacebo -> bucket_floor(*mom_var, placebo_labels(*pilot_labels, placebo_seed))
//   Guarded       -> guard_score(bucket_floor(*pilot_var, *pilot_labels), *untrusted)
//   Shrink        -> shrink_score(*pilot_var, *pilot_labels, pilot_spp)
//   RobustAdaptive -> adaptive_mom_score(*pilot_var, *mom_var, *pilot_labels, rare)
//   ShrinkGlobal  -> shrink_score(*pilot_var, one_population(*pilot_labels), pilot_spp): the same
//                    shrinkage towards one prior fitted over every labelled pixel, so what shrink
//                    gains beyond it is the label's (the paper's bucket-free global-shrinkage placebo)
// placebo_seed is used by the two placebo strategies only.
// Throws std::invalid_argument when sizes differ (bucket_floor and the other
// scores) or shrink has pilot_spp < 2. A needed pointer left null, or Uniform
// given no input at all, is the caller's bug: InternalError naming the missing
// input (e.g. "oracle_var"); the front ends refuse the oracle strategies first.
std::vector<double> strategy_score(Strategy s, const ScoreInputs& in, uint64_t placebo_seed);

}  // namespace vkmech::alloc
