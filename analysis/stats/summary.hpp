// Summary statistics of a sample: mean, variance, median, quantiles.
//
// docs/descriptor.md §5 uses these for sigma^2_intrinsic (K * Var over seeds, ddof 1), the
// split-half mean over partitions, per-bucket medians, and the quantile bin
// edges of the variance-agreement analysis (see quantiles.hpp).
#pragma once

#include <vector>

namespace vkmech::stats {

// Arithmetic mean; NaN for an empty sample.
double mean(const std::vector<double>& x);

// Unbiased sample variance (ddof 1), two-pass: the mean is subtracted before
// squaring, which keeps precision for per-seed luminances that are large
// compared to their spread (docs/descriptor.md §5: Var over 10 seeds, ddof 1).
// NaN for n < 2.
double sample_variance(const std::vector<double>& x);

// Median (the average of the two middle values for an even count, i.e. type-7
// quantile 0.5). NaN for an empty sample or if any value is NaN (NaN has no
// position in an order, so there is no honest median to report).
double median(std::vector<double> x);

// Quantile with linear interpolation between order statistics, Hyndman-Fan
// "type 7" (numpy's default): h = (n-1) q, result = x[floor h] +
// (h - floor h) (x[floor h + 1] - x[floor h]) on the sorted sample.
// NaN for an empty sample or if any value is NaN.
// Throws std::invalid_argument unless 0 <= q <= 1.
double quantile(std::vector<double> x, double q);

// Type-7 quantile of an already ascending-sorted, NaN-free sample; the
// building block of quantile() and quantile_edges() (one sort, many q).
// NaN for an empty sample. Throws std::invalid_argument unless 0 <= q <= 1.
double quantile_sorted(const std::vector<double>& sorted, double q);

}  // namespace vkmech::stats
