// The label as a prior on the pilot variance: the empirical-Bayes `shrink`
// strategy (docs/descriptor.md §6.6; the paper's Future Work).
//
// A pilot of N0 samples measures each pixel's variance sigma^2(p) with an
// error that is large in relative terms (a few samples) and worst where the
// transport is heavy-tailed. Pixels that share a mechanism label share much of
// their variance structure, so the label's pixels form a population whose
// spread is a prior for each member. On the log scale, with
// y(p) = log sigma^2(p):
//   - the sampling variance of y for N0 Gaussian samples is
//     v = trigamma((N0 - 1) / 2) (about 2 / (N0 - 1));
//   - per label b, the pixels with a positive finite sigma^2 give the prior
//     mean mu_b (their mean y) and the prior variance
//     tau2_b = max(0, S2_b - v), S2_b their sample variance (ddof 1;
//     0 with fewer than 2 pixels): the spread left after the noise is taken out;
//   - the posterior mean is y'(p) = mu_b + w_b (y(p) - mu_b) with
//     w_b = tau2_b / (tau2_b + v), and D(p) = exp(y'(p)).
// A pixel of label b whose sigma^2 is 0 or not finite gets exp(mu_b): the
// pilot saw light there (it has a label) but measured no spread, so the
// label's typical variance stands in. A label none of whose pixels has a
// positive finite sigma^2 (an emitter seen directly, constant) keeps
// D = sigma^2 (0), and unlabelled pixels (gpu::NO_LABEL: no energy in the
// pilot) keep their sigma^2 too: no prior speaks for them.
// The common bias of log s^2 is the same for every pixel and cancels in the
// Neyman allocation (only ratios of sqrt(D) matter). Heavy tails make the true
// sampling variance of y larger than v, so the shrinkage is, if anything,
// too weak on heavy-tailed labels.
#pragma once

#include <cstdint>
#include <vector>

namespace vkmech::alloc {

// trigamma(x) = d^2/dx^2 log Gamma(x) for x > 0 (recurrence to x >= 12, then
// the asymptotic series; relative error below 1e-12). Throws
// std::invalid_argument for x <= 0 or non-finite x.
double trigamma(double x);

// The sampling variance of log s^2 for n Gaussian samples: trigamma((n - 1) / 2).
// Throws std::invalid_argument for n < 2.
double log_variance_noise(uint32_t n);

// Per-label prior fitted from the pilot (for the report and the tests).
struct ShrinkPrior {
    uint32_t pixels = 0;  // pixels with this label and a positive finite sigma^2
    double mu = 0.0;      // mean of log sigma^2 over them
    double tau2 = 0.0;    // prior variance, max(0, S2 - v)
    double weight = 0.0;  // w = tau2 / (tau2 + v): the share of a pixel's own deviation kept
};

// The prior of every label 0..255 (index = label; unused labels have pixels = 0).
std::vector<ShrinkPrior> fit_shrink_priors(const std::vector<double>& var, const std::vector<uint8_t>& labels,
                                           uint32_t pilot_spp);

// D(p) as described above. Throws std::invalid_argument if the sizes differ or
// pilot_spp < 2.
std::vector<double> shrink_score(const std::vector<double>& var, const std::vector<uint8_t>& labels,
                                 uint32_t pilot_spp);

}  // namespace vkmech::alloc
