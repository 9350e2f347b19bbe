// Mechanism-conditioned pilot correction: the bucket floor and its placebo.
//
// docs/descriptor.md §6 / paper §7 "Downstream Demonstration": for pixels whose pilot label
// lies in the heavy-tailed family {glossy, delta_mediated, specular_direct},
// the pilot variance sigma^2(p) is replaced by max(sigma^2(p), med_b), med_b
// being the median pilot variance of the pixels sharing that label. On those
// pixels a small pilot usually misses the tail, so sigma^2 is biased low
// exactly where the label says the tail lives; light-tailed pixels (and the
// unlabelled class 255) are left untouched. The random-partition placebo
// applies the same floor to a label map with identical class sizes but a
// shuffled pixel assignment, to test whether coarse partitioning alone
// explains any gain.
#pragma once

#include "allocation/adaptive_mom.hpp"
#include "shared/types.h"

#include <cstdint>
#include <vector>

namespace vkmech::alloc {

// The label classes the floor and the guard treat apart, a bit per class: the paper's buckets by
// default; a user taxonomy's classes as its lines declare them (docs/lpe.md, `[heavy]` and
// `[constant]`, `[rare]`).
struct ClassTraits {
    // The heavy-tailed family, which the floor floors (gpu::HEAVY_BUCKETS: glossy, delta_mediated,
    // specular_direct).
    uint32_t heavy = gpu::HEAVY_BUCKETS;
    // Classes whose energy is constant per pixel (an emitter seen directly): a pixel whose pilot energy
    // lies in them alone may truly have zero variance, and the guard trusts it (guard.hpp).
    uint32_t constant = 1u << gpu::BUCKET_EMITTER_DIRECT;
    // The rare-tail classes, where robust-adaptive keeps the plain pilot variance (adaptive_mom.hpp:
    // delta_mediated, specular_direct).
    uint32_t rare = kRareTailBuckets;
};

// True for a label in the heavy-tailed family `heavy` (a bit per class; the paper's by default);
// false for every other class and for gpu::NO_LABEL.
constexpr bool is_heavy_tailed(uint8_t label, uint32_t heavy = gpu::HEAVY_BUCKETS) {
    return label < gpu::BUCKET_COUNT && ((heavy >> label) & 1u) != 0;
}

// D(p) = max(var(p), median of var over the pixels with label labels[p]) for
// heavy-tailed labels; D(p) = var(p), copied bit for bit, for every other
// pixel. If no pixel is heavy-tailed the output equals the input exactly.
// Definition choices for non-finite values (a pilot of N0 >= 2 frames gives
// none, so they only matter for robustness):
//  - the per-label median is taken over the FINITE variances of that label
//    (type-7 median: the mean of the two middle values for an even count);
//  - a pixel whose own variance is non-finite keeps it unchanged (NaN/inf is
//    passed through, for the Neyman allocator to count, see neyman.hpp);
//  - a label whose variances are all non-finite has no floor.
// Throws std::invalid_argument if the sizes differ.
// `heavy`: the heavy-tailed family, a bit per class (ClassTraits::heavy).
std::vector<double> bucket_floor(const std::vector<double>& var, const std::vector<uint8_t>& labels,
                                 uint32_t heavy = gpu::HEAVY_BUCKETS);

// A uniformly random permutation of the label map: identical class sizes
// (the 255 class included), pixel assignment shuffled. Deterministic for a
// seed on every platform: Fisher-Yates from the top, driven by one splitmix64
// stream started at `seed`, indices drawn by rejection sampling
// (stats::uniform_below); std::shuffle and std::uniform_int_distribution are
// implementation-defined and are not used. The study draws a fresh seed per
// pilot draw ("fresh per draw", docs/descriptor.md §6).
std::vector<uint8_t> placebo_labels(const std::vector<uint8_t>& labels, uint64_t seed);

}  // namespace vkmech::alloc
