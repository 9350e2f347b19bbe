#include "stats/rank.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace vkmech::stats {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool is_constant(const std::vector<double>& x) {
    return std::all_of(x.begin(), x.end(), [&](double v) { return v == x.front(); });
}
}  // namespace

std::vector<double> average_ranks(const std::vector<double>& x) {
    for (double v : x)
        if (std::isnan(v)) throw std::invalid_argument("stats::average_ranks: NaN has no rank");
    std::vector<size_t> order(x.size());
    std::iota(order.begin(), order.end(), size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return x[a] < x[b]; });
    std::vector<double> r(x.size());
    for (size_t i = 0; i < order.size();) {
        size_t j = i + 1;
        while (j < order.size() && x[order[j]] == x[order[i]]) ++j;
        // Sorted positions i..j-1 hold ranks i+1..j; their mean is (i+1+j)/2.
        const double avg = 0.5 * static_cast<double>(i + 1 + j);
        for (size_t k = i; k < j; ++k) r[order[k]] = avg;
        i = j;
    }
    return r;
}

double pearson(const std::vector<double>& x, const std::vector<double>& y) {
    if (x.size() != y.size()) throw std::invalid_argument("stats::pearson: size mismatch");
    const size_t n = x.size();
    if (n < 2) return kNaN;
    for (size_t i = 0; i < n; ++i)
        if (!std::isfinite(x[i]) || !std::isfinite(y[i])) return kNaN;
    // Exact constancy test: the two-pass deviations of a constant sample can
    // be tiny non-zero rounding residue, which would give a meaningless r.
    if (is_constant(x) || is_constant(y)) return kNaN;
    double mx = 0, my = 0;
    for (size_t i = 0; i < n; ++i) {
        mx += x[i];
        my += y[i];
    }
    mx /= static_cast<double>(n);
    my /= static_cast<double>(n);
    double sxy = 0, sxx = 0, syy = 0;
    for (size_t i = 0; i < n; ++i) {
        const double dx = x[i] - mx, dy = y[i] - my;
        sxy += dx * dy;
        sxx += dx * dx;
        syy += dy * dy;
    }
    if (sxx <= 0.0 || syy <= 0.0) return kNaN;
    const double r = sxy / std::sqrt(sxx * syy);
    return std::clamp(r, -1.0, 1.0);
}

double spearman(const std::vector<double>& x, const std::vector<double>& y) {
    if (x.size() != y.size()) throw std::invalid_argument("stats::spearman: size mismatch");
    if (x.size() < 2) return kNaN;
    for (size_t i = 0; i < x.size(); ++i)
        if (std::isnan(x[i]) || std::isnan(y[i])) return kNaN;
    return pearson(average_ranks(x), average_ranks(y));
}

double masked_spearman(const std::vector<double>& x, const std::vector<double>& y, const std::vector<uint8_t>& mask,
                       size_t min_pairs) {
    if (x.size() != y.size() || mask.size() != x.size())
        throw std::invalid_argument("masked_spearman: x, y and the mask differ in size");
    std::vector<double> a, b;
    for (size_t i = 0; i < x.size(); ++i)
        if (mask[i] && std::isfinite(x[i]) && std::isfinite(y[i])) {
            a.push_back(x[i]);
            b.push_back(y[i]);
        }
    if (a.size() < min_pairs) return std::numeric_limits<double>::quiet_NaN();
    return spearman(a, b);
}

}  // namespace vkmech::stats
