// Two-stage adaptive rendering (docs/descriptor.md §6, paper §7): a pilot of N0 samples
// gives the pilot variance, the pilot labels and (for the robust strategies)
// the median-of-means variance; a strategy turns them into a score D(p); the
// extra budget is allocated Neyman-proportionally, n(p) ∝ sqrt(D(p)), with a
// per-pixel floor and identical totals for every strategy; the final image is
// n(p) samples per pixel of the pool seed, rendered on the GPU.
#pragma once

#include "allocation/allocation.hpp"
#include "render/descriptor.hpp"
#include "render/renderer.hpp"

#include <optional>
#include <string>
#include <vector>

namespace vkmech {

// docs/descriptor.md §4 downstream seed layout. A "frame" is one sample index of a seed, so
// the first n frames of the pool are samples [0, n) of the pool seed.
namespace downstream_seeds {
constexpr uint32_t kPool = 1000;
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

// Renders the pilot of `n0` samples of `seed`. With `robust`, the batches are
// the median-of-means blocks (k = ceil(sqrt(n0)) contiguous blocks; the
// remainder is rendered but left out of the MoM) — throws std::invalid_argument
// where MoM is not defined (N0 = 4).
Pilot render_pilot(Renderer& r, uint32_t n0, uint32_t seed, bool robust);

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
