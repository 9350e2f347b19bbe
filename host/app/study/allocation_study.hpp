// `vkmech study allocation` (docs/descriptor.md §6, paper §7): per scene an independent
// reference (chunks 900000 + c), the shared 256-frame pool (seed 1000, one
// frame per sample index, kept per frame so any n(p) is a prefix mean), and K
// disjoint pilot draws per N0 (seed 100000 + 1000k); every strategy's
// allocation is evaluated against the reference, and each strategy's wall
// time (pilot + allocation + a real GPU render of its n(p)) is measured.
#pragma once

#include "experiments/study_context.hpp"
#include "render/gpu_scene.hpp"
#include "study/render_cache.hpp"
#include "vk/context.hpp"

#include <functional>

namespace vkmech {

struct AllocationStudyContext {
    const StudyConfig& cfg;
    StudyOutput& out;
    const vk::Context& ctx;
    Traversal traversal;
    const RenderCache& cache;
    std::string code_digest;
    std::function<bool()> interrupted;
};

void run_allocation_study(AllocationStudyContext& a);

}  // namespace vkmech
