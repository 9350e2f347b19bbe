// Agreement between two per-pixel label maps.
//
// Labels are one byte per pixel: classes 0..k-1, and kNoLabel (255) for a
// pixel without a label (zero energy / background). docs/descriptor.md §5 "Agreement":
// the share of labelled pixels whose dominant label matches between two
// renders. "Labelled" means labelled in BOTH maps: a pixel labelled in only
// one map has nothing to compare with, so it is left out of the confusion
// matrix and of every score built from it (agreement, kappa, weighted kappa,
// struct%); labelled_in_one_only() counts these pixels so a caller can report
// them. Pixel shares and drift are the exception: each map's shares are over
// that map's own labelled pixels.
#pragma once

#include "shared/types.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vkmech::stats {

// The "no label" value of docs/descriptor.md §3 (shared/types.h, a plain header: the
// statistics library still does not depend on the renderer headers).
inline constexpr uint8_t kNoLabel = gpu::NO_LABEL;

// k x k contingency table over the pixels labelled in both maps.
struct Confusion {
    int k = 0;
    std::vector<double> counts;  // k*k row-major: row = label in a, column = label in b
    double total() const;
    double at(int i, int j) const {
        return counts[static_cast<std::size_t>(i) * static_cast<std::size_t>(k) + static_cast<std::size_t>(j)];
    }
};

// Throws std::invalid_argument on a size mismatch, k outside 1..255, or a
// label that is neither < k nor kNoLabel.
Confusion confusion(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int k);

// Pixels labelled in exactly one of the two maps (excluded from confusion()).
// Throws std::invalid_argument on a size mismatch.
uint64_t labelled_in_one_only(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b);

// Raw agreement = trace / total; NaN if no pixel is labelled in both maps.
double agreement(const Confusion& c);

// Share of the map's labelled pixels carrying each class (size k, sums to 1);
// all NaN if the map has no labelled pixel. Throws like confusion().
std::vector<double> pixel_shares(const std::vector<uint8_t>& labels, int k);

// docs/descriptor.md §5 "max drift": max over classes of |share_a - share_b|, each map's
// shares over its own labelled pixels (the maps may differ in size).
// NaN if either map has no labelled pixel.
double max_drift(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int k);

// Cohen's kappa (Po - Pe) / (1 - Pe), Pe from the row and column marginals.
// NaN if the table is empty or Pe == 1 (both maps use one and the same class:
// agreement beyond chance is 0/0).
double cohen_kappa(const Confusion& c);

// Weighted kappa with agreement weights w (k*k row-major, 1 on the diagonal,
// values in [0, 1]): kappa_w = (Po_w - Pe_w) / (1 - Pe_w) with
// Po_w = sum_ij w_ij p_ij and Pe_w = sum_ij w_ij p_i. p_.j.
// NaN if the table is empty or Pe_w == 1. Throws std::invalid_argument if w
// has the wrong size, a diagonal entry other than 1, or an entry outside [0, 1].
double weighted_kappa(const Confusion& c, const std::vector<double>& agreement_weights);

// docs/descriptor.md §5 kappa weights: agreement weight = 1 - penalty, penalty 0.2 for a
// swap between two light-tailed classes and 1.0 otherwise, so w_ii = 1,
// w_ij = 0.8 if both i and j are light-tailed, else 0.
// Throws std::invalid_argument unless light_tailed.size() == k.
std::vector<double> spec_kappa_weights(int k, const std::vector<bool>& light_tailed);

// docs/descriptor.md §5 "struct%": share of the disagreeing (off-diagonal) mass whose swap
// touches the heavy family, i.e. the row class or the column class is heavy.
// NaN if there is no disagreement. Throws std::invalid_argument unless
// heavy.size() == c.k.
double structural_share(const Confusion& c, const std::vector<bool>& heavy);

}  // namespace vkmech::stats
