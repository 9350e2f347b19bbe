#include "stats/cost.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace vkmech::stats {

CostMap time_to_quality(const std::vector<uint32_t>& levels, const std::vector<std::vector<double>>& lum_at_level,
                        const std::vector<double>& lum_ref, double tau, double eps) {
    if (levels.empty()) throw std::invalid_argument("stats::time_to_quality: no levels");
    for (size_t l = 1; l < levels.size(); ++l)
        if (levels[l] <= levels[l - 1])
            throw std::invalid_argument("stats::time_to_quality: levels must be strictly ascending");
    if (lum_at_level.size() != levels.size())
        throw std::invalid_argument("stats::time_to_quality: one luminance map per level required");
    for (const auto& m : lum_at_level)
        if (m.size() != lum_ref.size())
            throw std::invalid_argument("stats::time_to_quality: map size differs from the reference");
    if (!(tau > 0.0) || !(eps > 0.0)) throw std::invalid_argument("stats::time_to_quality: tau and eps must be > 0");

    const size_t P = lum_ref.size();
    const double cap = static_cast<double>(levels.back());
    CostMap out;
    out.spp.assign(P, cap);
    out.censored.assign(P, 1);
    for (size_t p = 0; p < P; ++p) {
        const double ref = lum_ref[p];
        if (!std::isfinite(ref)) continue;            // nothing to converge to: censored
        const double denom = std::max(ref, eps);      // docs/descriptor.md §5: max(lum(I_ref), 1e-4)
        for (size_t l = 0; l < levels.size(); ++l) {  // docs/descriptor.md §5: first-crossing rule
            const double v = lum_at_level[l][p];
            if (!std::isfinite(v)) continue;
            if (std::fabs(v - ref) / denom < tau) {
                out.spp[p] = static_cast<double>(levels[l]);
                out.censored[p] = 0;
                break;
            }
        }
    }
    return out;
}

CensoredMedian censored_median(const std::vector<double>& cost, const std::vector<uint8_t>& censored) {
    if (cost.size() != censored.size()) throw std::invalid_argument("stats::censored_median: size mismatch");
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const size_t n = cost.size();
    if (n == 0) return {nan, false, nan, 0};
    std::vector<double> observed;
    double cap = -std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < n; ++i) {
        if (std::isnan(cost[i])) throw std::invalid_argument("stats::censored_median: NaN cost");
        cap = std::max(cap, cost[i]);
        if (!censored[i]) observed.push_back(cost[i]);
    }
    std::sort(observed.begin(), observed.end());
    const double rate = static_cast<double>(n - observed.size()) / static_cast<double>(n);
    const size_t pos = (n - 1) / 2;  // lower middle for even n
    if (pos < observed.size()) return {observed[pos], false, rate, n};
    return {cap, true, rate, n};
}

}  // namespace vkmech::stats
