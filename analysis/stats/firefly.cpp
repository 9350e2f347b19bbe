#include "stats/firefly.hpp"

#include "stats/summary.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace vkmech::stats {

double firefly_ratio(const std::vector<double>& per_seed) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    if (per_seed.empty()) return nan;
    for (double v : per_seed)
        if (!std::isfinite(v)) return nan;
    const double m = mean(per_seed);
    if (!(m > 0.0)) return nan;
    return *std::max_element(per_seed.begin(), per_seed.end()) / m;
}

}  // namespace vkmech::stats
