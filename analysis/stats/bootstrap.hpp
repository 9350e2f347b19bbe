// Confidence intervals for map-comparison scores (agreement, kappa) by a
// tile bootstrap. Labels are spatially correlated (a mislabelled region is
// many neighbouring pixels), so resampling single pixels as if they were
// independent would understate the uncertainty; the image is cut into square
// tiles, tiles are resampled with replacement, and the score is recomputed
// on the resampled confusion matrix (the sum of the tiles' own matrices).
// Percentile intervals.
#pragma once

#include "stats/agreement.hpp"

#include <cstdint>
#include <functional>
#include <vector>

namespace vkmech::stats {

struct Interval {
    double lo = 0.0, hi = 0.0;  // NaN when no resample gave a finite score
};

// a and b: two label maps of `width` x (size / width) pixels; `tile`: the
// tile edge in pixels (1 = a plain pixel bootstrap; edge tiles may be
// smaller). `statistic` is evaluated on each resample's confusion matrix;
// NaN values are left out. Deterministic for a given seed. Throws
// std::invalid_argument on a size mismatch, width or tile < 1, a size not
// divisible by width, resamples < 10, or level outside (0, 1).
Interval tile_bootstrap(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int k, int width, int tile,
                        const std::function<double(const Confusion&)>& statistic, int resamples = 2000,
                        uint64_t seed = 0, double level = 0.95);

// The same tile bootstrap for a per-pixel rank correlation: x and y are two
// per-pixel fields of `width` x (size / width) pixels; a pixel where either is
// NaN is left out (unlabelled). Each resample draws whole tiles with
// replacement and recomputes Spearman's rho on the pixels they hold; NaN
// values (a constant field in the resample) are left out. Throws
// std::invalid_argument as tile_bootstrap does.
Interval tile_bootstrap_spearman(const std::vector<double>& x, const std::vector<double>& y, int width, int tile,
                                 int resamples = 1000, uint64_t seed = 0, double level = 0.95);

}  // namespace vkmech::stats
