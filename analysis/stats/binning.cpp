#include "stats/binning.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace vkmech::stats {

BinnedRate binned_rate(const std::vector<double>& x, const std::vector<uint8_t>& hit, int bins, double lo, double hi) {
    if (x.size() != hit.size()) throw std::invalid_argument("stats::binned_rate: size mismatch");
    if (bins < 1) throw std::invalid_argument("stats::binned_rate: bins must be >= 1");
    if (!std::isfinite(lo) || !std::isfinite(hi) || !(lo < hi))
        throw std::invalid_argument("stats::binned_rate: need finite lo < hi");
    const size_t B = static_cast<size_t>(bins);
    BinnedRate r;
    r.lo.resize(B);
    r.hi.resize(B);
    for (size_t b = 0; b < B; ++b) r.lo[b] = lo + (hi - lo) * static_cast<double>(b) / bins;
    for (size_t b = 0; b + 1 < B; ++b) r.hi[b] = r.lo[b + 1];
    r.hi[B - 1] = hi;
    r.count.assign(B, 0.0);
    r.hits.assign(B, 0.0);
    for (size_t i = 0; i < x.size(); ++i) {
        const double v = x[i];
        if (!(v >= lo && v <= hi)) continue;  // outside, or NaN
        double f = std::floor((v - lo) / (hi - lo) * bins);
        size_t b = std::min(static_cast<size_t>(f), B - 1);  // f >= 0 since v >= lo
        // The division can round across an edge; settle against the stored
        // edges so a value's bin always agrees with the reported [lo, hi).
        while (b > 0 && v < r.lo[b]) --b;
        while (b + 1 < B && v >= r.lo[b + 1]) ++b;
        r.count[b] += 1.0;
        if (hit[i]) r.hits[b] += 1.0;
    }
    r.rate.resize(B);
    for (size_t b = 0; b < B; ++b)
        r.rate[b] = r.count[b] > 0.0 ? r.hits[b] / r.count[b] : std::numeric_limits<double>::quiet_NaN();
    return r;
}

}  // namespace vkmech::stats
