// Ordinary least squares of y on x.
//
// docs/descriptor.md §5 "Convergence exponent": per pixel, unweighted OLS of log10 variance
// on log10 SPP over the 4 levels; alpha_hat = -slope, and R^2 is stored
// alongside. The exclusion of pixels with non-positive or non-finite variance
// happens in the caller, before the logarithm.
#pragma once

#include <vector>

namespace vkmech::stats {

struct OlsFit {
    double slope;
    double intercept;
    double r2;  // 1 - SSres / SStot; NaN when SStot == 0 (y constant)
};

// Unweighted least-squares line y = intercept + slope * x.
// Throws std::invalid_argument on a size mismatch or fewer than 2 distinct
// x values (the slope is then undetermined).
OlsFit ols(const std::vector<double>& x, const std::vector<double>& y);

}  // namespace vkmech::stats
