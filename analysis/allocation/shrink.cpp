#include "allocation/shrink.hpp"

#include "shared/types.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace vkmech::alloc {

double trigamma(double x) {
    if (!(x > 0.0) || !std::isfinite(x)) throw std::invalid_argument("alloc::trigamma: x must be positive and finite");
    double sum = 0.0;
    while (x < 12.0) {  // trigamma(x) = 1 / x^2 + trigamma(x + 1)
        sum += 1.0 / (x * x);
        x += 1.0;
    }
    const double r = 1.0 / x, r2 = r * r;
    // 1/x + 1/(2x^2) + sum_k B_2k / x^(2k+1): 1/6, -1/30, 1/42, -1/30, 5/66, -691/2730 (next term < 1e-16 at x = 12)
    sum += r + 0.5 * r2 +
           r * r2 *
               (1.0 / 6.0 + r2 * (-1.0 / 30.0 +
                                  r2 * (1.0 / 42.0 + r2 * (-1.0 / 30.0 + r2 * (5.0 / 66.0 + r2 * (-691.0 / 2730.0))))));
    return sum;
}

double log_variance_noise(uint32_t n) {
    if (n < 2) throw std::invalid_argument("alloc::log_variance_noise: at least 2 samples, got " + std::to_string(n));
    return trigamma(0.5 * (static_cast<double>(n) - 1.0));
}

namespace {

bool usable(double v) { return std::isfinite(v) && v > 0.0; }

}  // namespace

std::vector<ShrinkPrior> fit_shrink_priors(const std::vector<double>& var, const std::vector<uint8_t>& labels,
                                           uint32_t pilot_spp) {
    if (var.size() != labels.size())
        throw std::invalid_argument("alloc::shrink: " + std::to_string(var.size()) + " variances but " +
                                    std::to_string(labels.size()) + " labels");
    const double v = log_variance_noise(pilot_spp);
    std::vector<ShrinkPrior> prior(256);
    std::vector<double> sum(256, 0.0);
    for (size_t p = 0; p < var.size(); ++p)
        if (usable(var[p])) {
            prior[labels[p]].pixels += 1;
            sum[labels[p]] += std::log(var[p]);
        }
    for (int b = 0; b < 256; ++b)
        if (prior[b].pixels > 0) prior[b].mu = sum[b] / prior[b].pixels;
    std::vector<double> ss(256, 0.0);  // two-pass variance
    for (size_t p = 0; p < var.size(); ++p)
        if (usable(var[p])) {
            const double d = std::log(var[p]) - prior[labels[p]].mu;
            ss[labels[p]] += d * d;
        }
    for (int b = 0; b < 256; ++b) {
        ShrinkPrior& pr = prior[b];
        const double s2 = pr.pixels >= 2 ? ss[b] / (pr.pixels - 1.0) : 0.0;
        pr.tau2 = std::max(0.0, s2 - v);
        pr.weight = pr.tau2 / (pr.tau2 + v);
    }
    return prior;
}

std::vector<double> shrink_score(const std::vector<double>& var, const std::vector<uint8_t>& labels,
                                 uint32_t pilot_spp) {
    const std::vector<ShrinkPrior> prior = fit_shrink_priors(var, labels, pilot_spp);
    std::vector<double> D(var);
    for (size_t p = 0; p < var.size(); ++p) {
        const ShrinkPrior& pr = prior[labels[p]];
        if (labels[p] == gpu::NO_LABEL || pr.pixels == 0) continue;  // no prior speaks for this pixel
        D[p] = usable(var[p]) ? std::exp(pr.mu + pr.weight * (std::log(var[p]) - pr.mu)) : std::exp(pr.mu);
    }
    return D;
}

}  // namespace vkmech::alloc
