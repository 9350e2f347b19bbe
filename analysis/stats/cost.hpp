// Time-to-quality per pixel and its censored median.
//
// docs/descriptor.md §5 "Time-to-quality": c(p) = smallest SPP in the ascending level grid
// (independent renders per level) with |lum(I_N) - lum(I_ref)| /
// max(lum(I_ref), 1e-4) < 0.10; reference = the seed-disjoint 4096 render;
// a pixel that never crosses is right-censored at the largest level. Per
// bucket the median cost is reported with its censoring rate, and a median
// that lands on a censored pixel is only a lower bound.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vkmech::stats {

struct CostMap {
    std::vector<double> spp;        // first crossing level, or the cap when censored
    std::vector<uint8_t> censored;  // 1 = never crossed (spp holds the cap)
};

// First-crossing rule over `levels` (strictly ascending SPP). The relative
// error uses the eps floor in the denominator so dark reference pixels do not
// demand an absolute error of ~0. A non-finite luminance at a level never
// crosses; a non-finite reference makes the pixel censored (no level can be
// compared with it).
// Throws std::invalid_argument for empty or non-ascending levels, per-level
// maps that do not match lum_ref in size, or tau / eps not > 0.
CostMap time_to_quality(const std::vector<uint32_t>& levels, const std::vector<std::vector<double>>& lum_at_level,
                        const std::vector<double>& lum_ref, double tau = 0.10, double eps = 1e-4);

struct CensoredMedian {
    double value;          // median cost; the cap when lower_bound
    bool lower_bound;      // the median position holds a censored pixel
    double censored_rate;  // censored / n (NaN for n == 0)
    size_t n;
};

// Median with censored values ordered after every observed value (their true
// cost is above the cap). For an even count the LOWER-middle element is the
// median, at 0-based sorted position (n-1)/2: averaging the two middle values
// could mean averaging with +infinity, and the lower-middle choice keeps the
// result an actual level of the grid. If that position falls among the
// censored values, value = the cap (the largest of all given costs) and
// lower_bound = true. value = NaN for n == 0.
// Throws std::invalid_argument on a size mismatch or a NaN cost.
CensoredMedian censored_median(const std::vector<double>& cost, const std::vector<uint8_t>& censored);

}  // namespace vkmech::stats
