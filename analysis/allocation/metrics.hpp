// Error metrics of the downstream experiment (docs/descriptor.md §6): MSE / PSNR against
// the independent reference, the p99 absolute error (tail metric), and the
// paired per-draw comparison over the K = 10 pilot draws.
#pragma once

#include <vector>

namespace vkmech::alloc {

// Mean of (a - ref)^2. NaN for empty inputs. Throws std::invalid_argument if
// the sizes differ.
double mse(const std::vector<double>& a, const std::vector<double>& ref);

// 10 log10(peak^2 / mse); +inf for mse == 0, NaN for a negative or NaN mse.
double psnr(double mse, double peak = 1.0);

// Type-7 quantile 0.99 of |a - ref| (stats::quantile). NaN for empty inputs
// or a NaN difference. Throws std::invalid_argument if the sizes differ.
double p99_abs_error(const std::vector<double>& a, const std::vector<double>& ref);

// Paired comparison of two error series over the same draws (lower error is
// better), reported as "wins / draws", e.g. 9/10:
//   wins       = #{i : treatment[i] < control[i]} (ties and NaN are not wins)
//   draws      = the number of paired draws n (NOT the number of ties)
//   mean_delta = mean(control - treatment): > 0 when the treatment's error is
//                lower on average (NaN for n = 0).
struct Paired {
    int wins = 0, draws = 0;
    double mean_delta = 0.0;
};

// Throws std::invalid_argument if the sizes differ.
Paired paired_wins(const std::vector<double>& treatment, const std::vector<double>& control);

}  // namespace vkmech::alloc
