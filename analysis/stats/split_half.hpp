// Random split-half partitions of the seed set.
//
// docs/descriptor.md §5 "Split-half reliability": Spearman rho between the sigma^2 fields
// of two disjoint 5-seed halves, averaged over 20 random 5+5 partitions of the
// 10 seeds, base seed 0. The partitions must be reproducible bit-for-bit on
// every platform, so the generator is our own splitmix64 with Fisher-Yates
// and rejection sampling (std::uniform_int_distribution and std::shuffle are
// implementation-defined).
#pragma once

#include <cstdint>
#include <vector>

namespace vkmech::stats {

struct Partition {
    std::vector<int> a, b;  // the two halves, each sorted ascending
};

// splitmix64 (Steele, Lea, Flood 2014): the state advances by the golden
// gamma and the output is a fixed mix; returns the next 64-bit value.
uint64_t splitmix64_next(uint64_t& state);

// Uniform integer in [0, bound), bound >= 1, by rejection of the biased low
// range of the 64-bit output (exactly uniform, platform independent).
uint64_t uniform_below(uint64_t& state, uint64_t bound);

// `count` distinct random splits of {0..n-1} into two halves of n/2 each.
// One splitmix64 stream seeded with base_seed drives Fisher-Yates shuffles;
// the first n/2 shuffled indices form `a`. A draw equal to an earlier one as
// an unordered pair {a, b} is rejected and redrawn, so the first m partitions
// of a longer request equal a shorter request of m.
// Throws std::invalid_argument if n is odd or < 2, count < 0, or count exceeds
// the number of distinct unordered splits C(n, n/2) / 2 (126 for n = 10).
std::vector<Partition> random_halves(int n, int count, uint64_t base_seed);

// C(n, n/2) / 2, saturating at UINT64_MAX; the number of distinct unordered
// equal splits of n (n even, >= 2).
uint64_t distinct_half_splits(int n);

}  // namespace vkmech::stats
