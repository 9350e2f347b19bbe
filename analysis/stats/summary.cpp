#include "stats/summary.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace vkmech::stats {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool any_nan(const std::vector<double>& x) {
    return std::any_of(x.begin(), x.end(), [](double v) { return std::isnan(v); });
}
}  // namespace

double mean(const std::vector<double>& x) {
    if (x.empty()) return kNaN;
    double s = 0.0;
    for (double v : x) s += v;
    return s / static_cast<double>(x.size());
}

double sample_variance(const std::vector<double>& x) {
    if (x.size() < 2) return kNaN;
    const double m = mean(x);
    double ss = 0.0;
    for (double v : x) ss += (v - m) * (v - m);
    return ss / static_cast<double>(x.size() - 1);
}

double median(std::vector<double> x) { return quantile(std::move(x), 0.5); }

double quantile_sorted(const std::vector<double>& sorted, double q) {
    if (!(q >= 0.0 && q <= 1.0)) throw std::invalid_argument("stats::quantile: q must lie in [0, 1]");
    if (sorted.empty()) return kNaN;
    const double h = static_cast<double>(sorted.size() - 1) * q;
    const double fl = std::floor(h);
    const size_t i = static_cast<size_t>(fl);
    if (i + 1 >= sorted.size()) return sorted.back();
    const double frac = h - fl;
    if (frac == 0.0) return sorted[i];  // exact order statistic, no 0 * inf
    return sorted[i] + frac * (sorted[i + 1] - sorted[i]);
}

double quantile(std::vector<double> x, double q) {
    if (!(q >= 0.0 && q <= 1.0)) throw std::invalid_argument("stats::quantile: q must lie in [0, 1]");
    if (x.empty() || any_nan(x)) return kNaN;
    std::sort(x.begin(), x.end());
    return quantile_sorted(x, q);
}

}  // namespace vkmech::stats
