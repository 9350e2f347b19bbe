// Neyman sample allocation with a per-pixel floor and cap, exact integer
// totals.
//
// docs/descriptor.md §6 / paper §7: every strategy allocates the same extra budget from a
// strategy-specific score D(p), Neyman-proportionally n(p) ∝ sqrt(D(p)).
// Study configuration (P = 256 * 256 pixels):
//   - total = P * (1 + 32): a per-pixel baseline of 1 sample plus an extra
//     budget of 32 SPP per pixel on average (kStudyExtraSpp);
//   - floor = 1 (primary configuration, f = 1): the baseline sample;
//   - floor = 4 (the f = 4 control): same total, the floor's samples are
//     deducted from the Neyman share (total - 4 P is shared instead of
//     total - P);
//   - cap = 256: a pixel cannot take more frames than the shared 256-frame
//     pool holds.
// Identical totals for every strategy are guaranteed by construction: the
// result always sums to exactly `total`.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vkmech::alloc {

inline constexpr uint32_t kStudyBaselineSpp = 1;   // per-pixel baseline = primary floor f = 1
inline constexpr uint32_t kStudyExtraSpp = 32;     // extra budget, SPP per pixel on average
inline constexpr uint32_t kStudyControlFloor = 4;  // the f = 4 control
inline constexpr uint32_t kStudyPoolFrames = 256;  // shared pool size = per-pixel cap

// The study's total budget: pixels * (kStudyBaselineSpp + extra_spp).
constexpr uint64_t study_total(uint64_t pixels, uint32_t extra_spp = kStudyExtraSpp) {
    return pixels * (static_cast<uint64_t>(kStudyBaselineSpp) + extra_spp);
}

// Integer per-pixel sample counts n(p), with
//   floor <= n(p) <= cap  and  sum_p n(p) == total  (exactly).
// Real-valued target: every pixel starts at `floor`; the remaining
// R = total - floor * P samples are shared in proportion to w(p) = sqrt(D(p))
// with D clamped to >= 0. Cap by iterative water-filling: pixels whose target
// exceeds `cap` are fixed at `cap` and the budget left is re-shared among the
// others in proportion to their weights, until no target exceeds `cap`.
// Degenerate weights: when the pixels still being shared all have weight 0
// (every D zero or non-finite, or every positive-weight pixel already at the
// cap), the budget left is shared uniformly among them.
// Non-finite D (NaN, +-inf) is treated as D = 0; the number of such pixels
// is written to *nonfinite when the pointer is given.
// Integer rounding by largest remainder: each pixel gets floor(target), then
// the samples still missing go one each to the largest fractional parts,
// ties broken by the lower pixel index (never past `cap`). A final exact
// correction pass guards against floating-point error, so the sum is exact
// for every input.
// Throws std::invalid_argument if floor > cap, total < floor * P or
// total > cap * P.
std::vector<uint32_t> neyman_allocation(const std::vector<double>& D, uint64_t total, uint32_t floor = 1,
                                        uint32_t cap = 256, size_t* nonfinite = nullptr);

}  // namespace vkmech::alloc
