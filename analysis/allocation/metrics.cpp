#include "allocation/metrics.hpp"

#include "stats/summary.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace vkmech::alloc {

namespace {
void same_size(size_t a, size_t b, const char* fn) {
    if (a != b)
        throw std::invalid_argument(std::string("alloc::") + fn + ": sizes differ (" + std::to_string(a) + " vs " +
                                    std::to_string(b) + ")");
}
}  // namespace

double mse(const std::vector<double>& a, const std::vector<double>& ref) {
    same_size(a.size(), ref.size(), "mse");
    if (a.empty()) return std::numeric_limits<double>::quiet_NaN();
    double s = 0.0;
    for (size_t i = 0; i < a.size(); ++i) {
        const double d = a[i] - ref[i];
        s += d * d;
    }
    return s / static_cast<double>(a.size());
}

double psnr(double mse, double peak) {
    if (std::isnan(mse) || mse < 0.0) return std::numeric_limits<double>::quiet_NaN();
    if (mse == 0.0) return std::numeric_limits<double>::infinity();
    return 10.0 * std::log10(peak * peak / mse);
}

double p99_abs_error(const std::vector<double>& a, const std::vector<double>& ref) {
    same_size(a.size(), ref.size(), "p99_abs_error");
    std::vector<double> e(a.size());
    for (size_t i = 0; i < a.size(); ++i) e[i] = std::fabs(a[i] - ref[i]);
    return stats::quantile(std::move(e), 0.99);
}

Paired paired_wins(const std::vector<double>& treatment, const std::vector<double>& control) {
    same_size(treatment.size(), control.size(), "paired_wins");
    Paired r;
    r.draws = static_cast<int>(treatment.size());
    std::vector<double> delta(treatment.size());
    for (size_t i = 0; i < treatment.size(); ++i) {
        if (treatment[i] < control[i]) ++r.wins;
        delta[i] = control[i] - treatment[i];
    }
    r.mean_delta = stats::mean(delta);
    return r;
}

}  // namespace vkmech::alloc
