// render --noise-threshold T (docs/descriptor.md §6.8): rounds of samples on the pixels whose
// estimated relative error is above T, until every pixel is below T or at max-spp, or the time
// limit. The rule (error estimate, ladder, targets, fit to the time left) is
// analysis/allocation/threshold.hpp; this renders its rounds.
#pragma once

#include "allocation/floor.hpp"
#include "allocation/strategy.hpp"
#include "render/renderer.hpp"

#include <cstdint>
#include <functional>
#include <vector>

namespace vkmech {

struct ThresholdSettings {
    double threshold = 0.05;  // T: the relative standard error each pixel's mean luminance should reach
    uint32_t min_spp = 16;    // every pixel's first round: samples [0, min_spp)
    uint32_t max_spp = 1024;
    double time_limit = 0.0;     // seconds of rendering (rounds and their planning); 0: none
    uint64_t sample_budget = 0;  // samples in all (pixels x average spp); 0: none. At least min_spp per pixel.
    alloc::Strategy rule = alloc::Strategy::Guarded;
    uint32_t seed = 0;
    uint32_t batch_spp = 8;
    alloc::ClassTraits traits;  // the labels' heavy and constant classes (a --taxonomy's declared ones)
};

struct ThresholdRound {
    uint32_t first = 0;  // the rung the round's pixels started at (the smallest, if several)
    uint64_t samples = 0;
    size_t pixels = 0;          // pixels that took samples
    size_t above = 0;           // pixels above T before the round (at max-spp or not)
    double worst = 0.0;         // the largest finite err before the round
    double seconds = 0.0;       // rendering
    double plan_seconds = 0.0;  // the error estimate and the targets before it
    bool cut_by_time = false;   // fit to the time left or the samples left
};

struct ThresholdResult {
    Frame frame;
    std::vector<double> err;  // the final estimate, per pixel
    std::vector<uint32_t> n;  // samples per pixel
    std::vector<ThresholdRound> rounds;
    size_t converged = 0, at_max = 0, unfinished = 0;  // err <= T; above T at max-spp; above T below max-spp
    bool time_limit_reached = false;
    bool budget_reached = false;  // the sample budget stopped it
    double seconds = 0.0;         // wall time of every round and its planning
};

// Progress: called with a line per round (done) and between batches (may throw to stop).
struct ThresholdCallbacks {
    std::function<void(const ThresholdRound&, size_t round)> on_round;
    std::function<void(uint32_t, uint32_t)> progress;
    // The frame so far (the rounds before, merged with the current round's batches so far) and the
    // error map the current round was planned from; called at most as often as `frame_due` says.
    std::function<bool()> frame_due;
    std::function<void(const Frame&, const std::vector<double>&)> on_frame;
};

ThresholdResult render_to_threshold(Renderer& renderer, const ThresholdSettings& s, const ThresholdCallbacks& cb = {});

}  // namespace vkmech
