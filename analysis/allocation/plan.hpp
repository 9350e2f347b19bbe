// The data of a two-stage allocation and the plan it produces
// (docs/descriptor.md §6, paper §7): the pilot (its variance, labels and, for
// the robust strategies, the median-of-means variance), the shared sample
// pool every final image is drawn from, the seeds of both (§4), and
// plan_allocation, which turns a strategy and a pilot into n(p). Pure CPU: the
// app layer renders pilots and pools (host/app/adaptive, host/app/study), the
// allocation experiment (analysis/experiments/allocation.hpp) scores them.
#pragma once

#include "allocation/strategy.hpp"
#include "render/frame.hpp"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace vkmech {

// docs/descriptor.md §4 downstream seed layout. A "frame" is one sample index of a seed, so
// the first n frames of the pool are samples [0, n) of the pool seed.
namespace downstream_seeds {
constexpr uint32_t kPool = 1000;
// The allocation study's pools: pool 0 is seed kPool, pool j seed kPool + j (j < 1000).
inline uint32_t pool(uint32_t index) { return kPool + index; }
// "pool" for pool 0, "pool j" for the others: how messages name them.
inline std::string pool_label(uint32_t index) {
    std::string s("pool");
    if (index) {
        s += ' ';
        s += std::to_string(index);
    }
    return s;
}
inline uint32_t pilot(uint32_t draw) { return 100000 + 1000 * draw; }
inline uint32_t reference_chunk(uint32_t c) { return 900000 + c; }
constexpr uint32_t kPoolSize = 256;
}  // namespace downstream_seeds

struct Pilot {
    Frame frame;
    std::vector<double> var;      // unbiased per-pixel luminance variance
    std::vector<uint8_t> labels;  // dominant bucket (255: none)
    std::vector<double> mom_var;  // median-of-means variance; empty when not requested
    double seconds = 0.0;         // GPU time of the pilot
};

// A pilot from its rendered frame (var, labels and seconds derived from it)
// and its median-of-means variance (empty, or one per pixel).
Pilot make_pilot(Frame frame, std::vector<double> mom_var);

// The shared pool of the allocation study: `frames` frames of the pool seed,
// frame f holding sample index f of every pixel as (r, g, b, finite), where
// finite is 1 for a finite sample and 0 for one the renderer counted out; and
// the pool's converged per-pixel luminance variance (the oracle's score).
struct SamplePool {
    uint32_t frames = 0;
    size_t pixels = 0;
    std::vector<float> samples;      // [frame][pixel] x 4
    std::vector<double> oracle_var;  // per pixel
    const float* at(uint32_t frame, size_t pixel) const {
        return &samples[(static_cast<size_t>(frame) * pixels + pixel) * 4];
    }
};

// A pilot's samples one by one: luminance of sample i of pixel p at
// lum[i * pixels + p], NaN for a sample the renderer counted out (non-finite).
// For the median-of-means block-count sweep, which needs the blocks of any k.
struct PilotSamples {
    uint32_t samples = 0;
    size_t pixels = 0;
    std::vector<float> lum;
    // Median over k contiguous blocks of floor(samples / k) samples (the
    // remainder discarded) of each block's unbiased luminance variance; blocks
    // with fewer than 2 finite samples of a pixel are left out of its median
    // (0 when none is left). Throws std::invalid_argument unless
    // 1 <= k and the block size is at least 2.
    std::vector<double> mom_variance(int k) const;
};

// A frame's per-pixel mean RGB over its finite samples (0 where it has none),
// in double, 3 per pixel: a reference's unclamped linear RGB (docs/descriptor.md §6).
std::vector<double> mean_rgb(const Frame& f);
// The final image of an allocation, 3 per pixel: the mean of the first n(p)
// pool frames of each pixel, non-finite samples counted out as the renderer
// does (0 where none is left).
std::vector<double> final_image_rgb(const SamplePool& pool, const std::vector<uint32_t>& n);
// The PSNR peak of a reference: its largest RGB value, 1 when none is positive.
double psnr_peak(const std::vector<double>& rgb);

struct AdaptivePlan {
    std::vector<uint32_t> n;  // samples per pixel
    double allocation_ms = 0.0;
    uint64_t total = 0;
};

// D(p) for the strategy and the Neyman allocation of (1 + extra_spp) samples
// per pixel on average (docs/descriptor.md §6: baseline 1 plus the extra budget; identical
// totals for every strategy), at least `floor` each, capped at the pool size.
AdaptivePlan plan_allocation(alloc::Strategy s, const alloc::ScoreInputs& in, uint32_t extra_spp, uint32_t floor,
                             uint64_t placebo_seed);

}  // namespace vkmech
