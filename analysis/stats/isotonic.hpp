// Weighted isotonic (monotone non-decreasing) regression.
//
// docs/descriptor.md §5 "Reliability predictor": the agreement rate per bin is pooled into a
// 20-bin monotone (isotonic) curve; bins are weighted by their pixel counts,
// and empty bins carry weight 0.
#pragma once

#include <vector>

namespace vkmech::stats {

// Pool-adjacent-violators: the non-decreasing sequence f minimising
// sum_i w_i (y_i - f_i)^2. Zero-weight entries do not influence the fit and
// take the value of their block neighbour: the fitted value of the nearest
// positive-weight entry to their LEFT, or to their right for leading entries
// (any value between the neighbours would keep f monotone; the left one is
// chosen so an empty bin never looks better than the data below it).
// All weights zero (no data): every entry is NaN.
// Throws std::invalid_argument on a size mismatch, a negative or non-finite
// weight, or a non-finite y with positive weight.
std::vector<double> isotonic_increasing(const std::vector<double>& y, const std::vector<double>& w);

}  // namespace vkmech::stats
