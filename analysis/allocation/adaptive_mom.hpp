// The per-bucket adaptive median-of-means block count: the `robust-adaptive`
// strategy (docs/descriptor.md §6.7).
//
// robust-var uses one block count k = ceil(sqrt(N0)) for every pixel. Median-
// of-means trades efficiency for robustness: the median of k block variances
// ignores a block whose variance a rare large sample inflated. That is what a
// mid-tail pixel wants (an occasional outlier is noise to be discounted) and
// what a rare-tail pixel does not want: where the pilot label says the
// transport is delta-mediated or specular-direct (a caustic seen through or
// off a delta surface), the rare large sample IS the pixel's variance, and a
// median over blocks discards it, starving exactly the pixels whose error
// dominates. robust-adaptive therefore picks k per pixel from its pilot label:
//   - delta_mediated, specular_direct (the rare-tail buckets): k = 1, i.e. the
//     plain pilot variance sigma^2 over all N0 samples (observed-var's score);
//   - every other bucket (emitter_direct, direct, diffuse_indirect, glossy,
//     other): k = ceil(sqrt(N0)), robust-var's median-of-means;
//   - unlabelled pixels (gpu::NO_LABEL: no energy in the pilot): k =
//     ceil(sqrt(N0)) too, i.e. robust-var's score. Such a pixel's finite pilot
//     samples are all 0, so both estimates are 0 whatever k (a pixel whose
//     samples were all counted out as non-finite has no variance either way).
// The rule was written down a priori from the paper's statement that rare-tail
// buckets degrade as k grows while mid-tail ones improve, and from the
// project's bucket taxonomy; it reads nothing but the pilot (its labels, its
// plain variance and its median-of-means variance), and it was not fitted to
// the study's block-count sweep (docs/results/allocation/ mom_sweep,
// mom_rank_fidelity). Only k = 1 and k = ceil(sqrt(N0)) are used, so the
// renderer's median-of-means blocks (host/app/adaptive render_pilot) give
// everything `render --adaptive robust-adaptive` needs: the study and the
// renderer compute the same score from the same Pilot.
#pragma once

#include "shared/types.h"

#include <cstdint>
#include <vector>

namespace vkmech::alloc {

// The rare-tail buckets, a bit per class: delta_mediated and specular_direct. A user taxonomy
// declares its own with `[rare]` (docs/lpe.md; ClassTraits::rare, floor.hpp); every function
// below takes that set, the paper's by default.
constexpr uint32_t kRareTailBuckets = (1u << gpu::BUCKET_DELTA_MEDIATED) | (1u << gpu::BUCKET_SPECULAR_DIRECT);

// True for a label in the rare-tail set `rare` (the paper's: delta_mediated and specular_direct),
// where robust-adaptive keeps the plain variance (k = 1); false for every other class and for
// gpu::NO_LABEL.
constexpr bool is_rare_tail(uint8_t label, uint32_t rare = kRareTailBuckets) {
    return label < gpu::BUCKET_COUNT && ((rare >> label) & 1u) != 0;
}

// The block count robust-adaptive uses for a pixel with pilot label `label`
// at pilot N0 = n0: 1 for a rare-tail label, mom_block_count(n0) otherwise
// (unlabelled included). Throws std::invalid_argument where median-of-means is
// not defined for n0 (mom_defined, e.g. N0 = 4).
int adaptive_mom_k(uint8_t label, int n0, uint32_t rare = kRareTailBuckets);

// D(p) = plain_var(p) (k = 1) where labels[p] is rare-tail, mom_var(p)
// (k = ceil(sqrt(N0))) everywhere else; each value copied bit for bit. With no
// rare-tail pixel the result is mom_var exactly (robust-var), with only
// rare-tail pixels plain_var exactly. Throws std::invalid_argument if the
// sizes differ.
std::vector<double> adaptive_mom_score(const std::vector<double>& plain_var, const std::vector<double>& mom_var,
                                       const std::vector<uint8_t>& labels, uint32_t rare = kRareTailBuckets);

// The number of pixels with a rare-tail label (where robust-adaptive differs
// from robust-var; 0: identical to robust-var bit for bit).
size_t rare_tail_pixels(const std::vector<uint8_t>& labels, uint32_t rare = kRareTailBuckets);

}  // namespace vkmech::alloc
