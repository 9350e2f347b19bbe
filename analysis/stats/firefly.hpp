// Firefly ratio of a pixel's per-seed values.
//
// docs/descriptor.md §5 "Firefly ratio" (paper §5.4): per pixel, the seed-wise max over
// the seed-wise mean of the glossy contribution. A ratio near 1 means every
// seed sees about the same energy; a large ratio means one seed caught a rare
// high-energy path (a firefly) that dominates the mean.
#pragma once

#include <vector>

namespace vkmech::stats {

// max / mean over seeds. NaN for an empty input, any non-finite value, or a
// mean <= 0 (a pixel with no glossy energy has no meaningful ratio).
double firefly_ratio(const std::vector<double>& per_seed);

}  // namespace vkmech::stats
