// Median-of-means (MoM) pilot variance: the robust-variance incumbent of the
// paper's Result-3 amendment (docs/descriptor.md §6 `robust-var`).
//
// The N0 pilot frames of a pixel, in render order, are cut into
// k = ceil(sqrt(N0)) contiguous blocks of floor(N0 / k) frames each; the
// trailing remainder N0 - k * floor(N0 / k) frames are discarded (and
// reported by mom_discarded). Each block gives an unbiased (ddof 1) variance
// m2 / (n - 1); the MoM variance is the median of the k block variances
// (type 7: the mean of the two middle values when k is even, e.g. k = 4 at
// N0 = 16).
//
//   N0 =  4: k = 2, blocks of 2  -> refused (see below; "n/a at N0 = 4")
//   N0 =  9: k = 3, blocks of 3
//   N0 = 16: k = 4, blocks of 4
//   N0 = 64: k = 8, blocks of 8
//
// Why blocks of fewer than 3 samples are refused: a 2-sample block variance
// is (x1 - x2)^2 / 2, a single squared difference with one degree of
// freedom (a scaled chi^2_1, whose median is ~0.45 of its mean and whose mass
// piles up near 0). The median of two such values is just their mean, i.e. no
// robustness at all, and for larger k the median of chi^2_1 variates is an
// estimate dominated by the near-zero mode rather than by the pixel's spread.
// The paper: "MoM is not meaningfully defined at N0 = 4 (two-sample blocks)".
// The block-count sensitivity sweep of the artifact (e.g. k = 8 at N0 = 16,
// two-sample blocks) uses the explicit-k overloads, which only require the
// ddof-1 variance to exist (blocks of >= 2).
#pragma once

#include <vector>

namespace vkmech::alloc {

// Moments of one block of one pixel: sample count, mean, and m2 = the sum of
// squared deviations from the block mean (Welford's M2), so the unbiased
// block variance is m2 / (n - 1).
struct BlockMoments {
    double n = 0.0, mean = 0.0, m2 = 0.0;
};

// Welford update of a block's moments with one more sample x.
void accumulate(BlockMoments& m, double x);

// Per pixel: the median over blocks of m2 / (n - 1). `blocks` is indexed
// [block][pixel]. A block with n < 2 (non-finite samples are not counted, so
// a block can be left with fewer than it was given) has no ddof-1 variance
// and is dropped from that pixel's median; a pixel with no block left gets 0,
// the same rule as PilotSamples::mom_variance. Throws std::invalid_argument if
// there are no blocks or the blocks cover different pixel counts. A NaN block
// variance makes that pixel's result NaN (stats::median).
std::vector<double> mom_variance(const std::vector<std::vector<BlockMoments>>& blocks);

// k = ceil(sqrt(N0)), computed in integers. Throws std::invalid_argument for
// N0 < 1.
int mom_block_count(int n0);

// floor(N0 / k) with k = mom_block_count(N0). Throws std::invalid_argument
// when that is below 3, e.g. "median-of-means needs blocks of at least 3
// samples; N0 = 4 gives 2 blocks of 2: not defined".
int mom_block_size(int n0);

// True where mom_block_size(N0) is defined (N0 >= 1 with blocks of at least 3 samples).
bool mom_defined(int n0);

// Frames discarded at the end of the pilot: N0 - k * mom_block_size(N0)
// (0 for the study's N0 = 9, 16, 64; e.g. 1 for N0 = 13). Throws like
// mom_block_size.
int mom_discarded(int n0);

// Explicit-k variants for the block-count sweep: floor(N0 / k) and
// N0 - k * floor(N0 / k). Throw std::invalid_argument unless 1 <= k and the
// block size is >= 2.
int mom_block_size(int n0, int k);
int mom_discarded(int n0, int k);

}  // namespace vkmech::alloc
