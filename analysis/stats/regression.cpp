#include "stats/regression.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace vkmech::stats {

OlsFit ols(const std::vector<double>& x, const std::vector<double>& y) {
    if (x.size() != y.size()) throw std::invalid_argument("stats::ols: size mismatch");
    if (x.empty() || std::all_of(x.begin(), x.end(), [&](double v) { return v == x.front(); }))
        throw std::invalid_argument("stats::ols: need at least 2 distinct x values");
    const double n = static_cast<double>(x.size());
    double mx = 0, my = 0;
    for (size_t i = 0; i < x.size(); ++i) {
        mx += x[i];
        my += y[i];
    }
    mx /= n;
    my /= n;
    double sxx = 0, sxy = 0;
    for (size_t i = 0; i < x.size(); ++i) {
        sxx += (x[i] - mx) * (x[i] - mx);
        sxy += (x[i] - mx) * (y[i] - my);
    }
    OlsFit f{};
    f.slope = sxy / sxx;
    f.intercept = my - f.slope * mx;
    // Exact constancy test for y (see rank.cpp: rounding residue of a constant
    // sample must not turn into a spurious R^2).
    if (std::all_of(y.begin(), y.end(), [&](double v) { return v == y.front(); })) {
        f.r2 = std::numeric_limits<double>::quiet_NaN();
        return f;
    }
    double ss_res = 0, ss_tot = 0;
    for (size_t i = 0; i < x.size(); ++i) {
        const double e = y[i] - (f.intercept + f.slope * x[i]);
        ss_res += e * e;
        ss_tot += (y[i] - my) * (y[i] - my);
    }
    f.r2 = ss_tot > 0.0 ? 1.0 - ss_res / ss_tot : std::numeric_limits<double>::quiet_NaN();
    return f;
}

}  // namespace vkmech::stats
