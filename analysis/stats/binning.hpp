// Hit rate per equal-width bin of a covariate.
//
// docs/descriptor.md §5 "Reliability predictor" (§8.2): agreement rate per pilot purity bin
// and per argmax-margin bin. The per-bin counts double as the weights of the
// pooled isotonic curve (isotonic.hpp).
#pragma once

#include <cstdint>
#include <vector>

namespace vkmech::stats {

struct BinnedRate {
    std::vector<double> lo, hi;  // bin b covers [lo[b], hi[b]); the last bin also holds x == hi
    std::vector<double> count;   // values that fell into the bin
    std::vector<double> hits;    // of those, with hit != 0
    std::vector<double> rate;    // hits / count; NaN for an empty bin
};

// `bins` equal-width bins on [lo, hi]; x == hi goes into the last bin; values
// outside [lo, hi] and NaN are ignored. A value exactly on an interior edge
// goes to the bin that starts there (consistent with the reported lo/hi).
// Throws std::invalid_argument on a size mismatch, bins < 1, or unless
// lo < hi are both finite.
BinnedRate binned_rate(const std::vector<double>& x, const std::vector<uint8_t>& hit, int bins, double lo, double hi);

}  // namespace vkmech::stats
