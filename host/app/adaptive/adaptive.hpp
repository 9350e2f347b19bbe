// Two-stage adaptive rendering (docs/descriptor.md §6, paper §7): a pilot of N0 samples
// gives the pilot variance, the pilot labels and (for the robust strategies)
// the median-of-means variance; a strategy turns them into a score D(p); the
// extra budget is allocated Neyman-proportionally, n(p) ∝ sqrt(D(p)), with a
// per-pixel floor and identical totals for every strategy; the final image is
// n(p) samples per pixel of the pool seed, rendered on the GPU.
#pragma once

#include "allocation/allocation.hpp"
#include "allocation/guard.hpp"
#include "allocation/plan.hpp"
#include "render/descriptor.hpp"
#include "render/renderer.hpp"
#include "render/taxonomy.hpp"

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace vkmech {

// Renders the pilot of `n0` samples of `seed`. With `robust`, the batches are
// the median-of-means blocks (k = ceil(sqrt(n0)) contiguous blocks; the
// remainder is rendered but left out of the MoM) — throws std::invalid_argument
// where MoM is not defined (N0 = 4).
// `progress`, when given, is called between batches (done, total) and may throw to stop.
Pilot render_pilot(Renderer& r, uint32_t n0, uint32_t seed, bool robust,
                   const std::function<void(uint32_t, uint32_t)>& progress = {});

// Strategy `s`'s allocation from a pilot of n0 samples and its diagnosis (allocation/guard.hpp):
// 1 + extra_spp samples per pixel on average, at least `floor` each; `pilot_draw` seeds the
// placebo. The robust strategies read the pilot's median-of-means variance. `traits`: the labels'
// heavy classes (a --taxonomy's declared ones; the paper's buckets by default).
AdaptivePlan plan_from_pilot(alloc::Strategy s, const Pilot& pilot, const alloc::PilotDiagnosis& diag, uint32_t n0,
                             uint32_t extra_spp, uint32_t floor, uint32_t pilot_draw,
                             const alloc::ClassTraits& traits = {});

// The heavy, constant and rare-tail classes of a render's labels: a taxonomy's declared ones, or, with
// none, the paper's buckets' (the ClassTraits defaults).
alloc::ClassTraits class_traits(const SceneTaxonomy* taxonomy);

// The provenance's sample range of a render with per-pixel counts n(p): "0:max n (adaptive: ...)".
std::string adaptive_sample_range(const std::vector<uint32_t>& n);

// The final render of a plan: pixel p takes exactly samples [0, n(p)) of the pool seed.
RenderSpec adaptive_render_spec(const AdaptivePlan& plan, uint32_t batch_spp);

}  // namespace vkmech
