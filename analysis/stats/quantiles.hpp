// Quantile binning of a continuous per-pixel field.
//
// docs/descriptor.md §5 "Quantile-binned variance agreement": per scene, bin edges are
// quantiles computed independently at each SPP level (3 and 7 bins); the two
// binned maps are then scored with the same agreement metric as the labels
// (agreement.hpp). Edges per level make the score about the ordering of
// pixels, not about the variance level, which shifts with SPP.
#pragma once

#include <cstdint>
#include <vector>

namespace vkmech::stats {

// The bins-1 interior edges at quantiles k/bins, k = 1..bins-1, type 7
// (see summary.hpp). Throws std::invalid_argument for an empty sample, a NaN
// value, or bins outside 1..255 (bin indices must stay below kNoLabel).
std::vector<double> quantile_edges(const std::vector<double>& values, int bins);

// Bin index of each value = number of edges strictly less than the value, so
// bin b covers (edge[b-1], edge[b]]. Tie rule: a value equal to an edge goes
// to the LOWER bin; when many values tie (e.g. a block of equal variances)
// they all land in the same bin instead of being split arbitrarily. Equal
// edges then leave the bins between them empty.
// Throws std::invalid_argument for a NaN value, unsorted edges, or more than
// 254 edges.
std::vector<uint8_t> quantile_bin(const std::vector<double>& values, const std::vector<double>& edges);

}  // namespace vkmech::stats
