// Ranks and correlation coefficients.
//
// docs/descriptor.md §5: split-half reliability is the Spearman rho between two sigma^2
// fields; the correlation-structure and cost analyses are per-pixel Spearman
// correlations. Many fields have large tied blocks (e.g. depth, zero
// fractions), so ties must get average ranks, as in scipy.stats.spearmanr.
#pragma once

#include <cstddef>
#include <cstdint>

#include <vector>

namespace vkmech::stats {

// 1-based ranks; tied values share the mean of the ranks they span
// (e.g. {10, 20, 20, 30} -> {1, 2.5, 2.5, 4}). +-infinity rank normally.
// Throws std::invalid_argument if any value is NaN (it has no rank).
std::vector<double> average_ranks(const std::vector<double>& x);

// Pearson product-moment correlation, clamped to [-1, 1].
// NaN if n < 2, if either input is constant (zero variance: the coefficient
// is 0/0), or if any value is non-finite.
// Throws std::invalid_argument if the sizes differ.
double pearson(const std::vector<double>& x, const std::vector<double>& y);

// Spearman rank correlation = Pearson correlation of the average ranks, so
// ties are handled exactly as scipy.stats.spearmanr does.
// NaN if n < 2, either input is constant, or any value is NaN (propagated as
// in scipy's default nan_policy rather than ranked arbitrarily).
// Throws std::invalid_argument if the sizes differ.
double spearman(const std::vector<double>& x, const std::vector<double>& y);

// spearman() over the pairs where mask[i] is non-zero and both values are finite (the analyses'
// foreground pixels); NaN with fewer than `min_pairs` such pairs. Throws std::invalid_argument
// if the sizes differ.
double masked_spearman(const std::vector<double>& x, const std::vector<double>& y, const std::vector<uint8_t>& mask,
                       size_t min_pairs = 2);

}  // namespace vkmech::stats
