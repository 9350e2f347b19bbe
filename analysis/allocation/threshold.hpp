// The noise threshold (render --noise-threshold; docs/descriptor.md §6.8): render in rounds, each
// giving more samples to the pixels whose estimated relative error is above a threshold T, until
// every pixel is below T or at the maximum, or the time is up. This file is the rule, pure CPU:
// the error estimate, the ladder of sample counts, the next round's targets and their fit to a
// time budget. The rounds themselves are rendered by host/app/adaptive/noise_threshold.cpp.
#pragma once

#include "allocation/floor.hpp"
#include "allocation/strategy.hpp"
#include "render/frame.hpp"

#include <cstdint>
#include <vector>

namespace vkmech::alloc {

// The dark floor of the relative error: delta = kDarkFloor times the image's mean luminance.
inline constexpr double kDarkFloor = 0.01;
// Successive rungs of the sample ladder differ by this factor, rounded up: sqrt(2), two rungs a doubling.
inline constexpr double kLadderRatio = 1.4142135623730951;
// A round gives a pixel at most this many times the samples it has.
inline constexpr uint32_t kMaxGrowth = 4;

// The estimated relative standard error of each pixel's mean luminance, from the frame so far:
//   err(p) = sqrt(D(p) / n(p)) / (mu(p) + delta)
// with
//   n(p)   the pixel's samples (finite and counted out);
//   D(p)   the score of strategy `s` (strategy.hpp) on the frame's unbiased luminance variance and
//          dominant labels: observed-var is the plain variance; bucket-floor floors heavy-tailed
//          labels at their bucket's median; guarded also raises each untrusted pixel (guard.hpp,
//          re-diagnosed on this frame) to at least the mean Neyman weight squared;
//   mu(p)  its mean luminance; for an untrusted pixel, the largest mean of its 3 x 3 window (a dark
//          pixel beside lit ones is measured against what its neighbours show);
//   delta  kDarkFloor times the image's mean luminance (over the pixels with samples).
// err is 0 where D(p) is 0 and mu + delta > 0 (a black pixel in a black image: 0 too), +inf where
// n(p) = 0 or D(p) is not finite. Only observed-var, bucket-floor and guarded are rules
// (std::invalid_argument otherwise): the others need inputs a render does not have. `traits`: the
// labels' heavy and constant classes (the paper's buckets, or a taxonomy's declared ones).
std::vector<double> relative_error(const Frame& frame, Strategy s, const ClassTraits& traits = {});

// The sample counts a pixel can stop at: min_spp, then each rung kLadderRatio times the last
// (rounded up, at least one more), up to max_spp, which is always the last rung.
// std::invalid_argument unless 1 <= min_spp <= max_spp.
std::vector<uint32_t> sample_ladder(uint32_t min_spp, uint32_t max_spp);

// The next round's end per pixel: a pixel above T (err > T) and below the last rung goes to the
// smallest rung at or above its predicted need n (err / T)^2, at least the next rung and at most
// kMaxGrowth n (then the rung just below, never less than the next); every other pixel keeps n
// (no samples). `n` holds each pixel's samples so far, each on the ladder (else
// std::invalid_argument).
std::vector<uint32_t> threshold_targets(const std::vector<uint32_t>& n, const std::vector<double>& err,
                                        double threshold, const std::vector<uint32_t>& ladder);

// Fits a round to at most `budget` samples: if its targets ask for more, every active pixel is cut to
// its next rung; if that is still too many, the pixels keep theirs in order of decreasing err (ties by
// index) while they fit, and the rest get none this round. Returns the samples the round now takes
// (0: none fit).
uint64_t fit_round(std::vector<uint32_t>& target, const std::vector<uint32_t>& n, const std::vector<double>& err,
                   const std::vector<uint32_t>& ladder, uint64_t budget);

// The samples each pixel has: finite plus counted out.
std::vector<uint32_t> pixel_samples(const Frame& frame);

}  // namespace vkmech::alloc
