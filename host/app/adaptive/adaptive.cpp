#include "adaptive/adaptive.hpp"

#include <chrono>
#include <stdexcept>

namespace vkmech {

Pilot render_pilot(Renderer& r, uint32_t n0, uint32_t seed, bool robust) {
    Pilot out;
    RenderSpec spec;
    spec.spp = n0;
    spec.seed = seed;
    spec.batch_spp = 8;
    std::vector<std::vector<alloc::BlockMoments>> blocks;
    int k = 0, size = 0;
    if (robust) {
        size = alloc::mom_block_size(static_cast<int>(n0));  // throws where MoM is undefined (N0 = 4)
        k = alloc::mom_block_count(static_cast<int>(n0));
        spec.batch_spp = static_cast<uint32_t>(size);  // one batch per contiguous block, in render order
        spec.on_batch = [&](const std::vector<gpu::GpuPixelAccum>& b) {
            if (static_cast<int>(blocks.size()) >= k) return;  // the trailing remainder is not used
            std::vector<alloc::BlockMoments> m(b.size());
            for (size_t p = 0; p < b.size(); ++p) m[p] = {b[p].rgb.w, b[p].lum.x, batch_lum_m2(b[p])};
            blocks.push_back(std::move(m));
        };
    }
    out.frame = r.render(spec);
    out.seconds = out.frame.seconds;
    out.var.resize(out.frame.pixels.size());
    for (size_t p = 0; p < out.var.size(); ++p) out.var[p] = out.frame.pixels[p].lum_var();
    out.labels = derive_descriptor(out.frame).dominant;
    if (robust) out.mom_var = alloc::mom_variance(blocks);
    return out;
}

AdaptivePlan plan_allocation(alloc::Strategy s, const alloc::ScoreInputs& in, uint32_t extra_spp, uint32_t floor,
                             uint64_t placebo_seed) {
    auto t0 = std::chrono::steady_clock::now();
    std::vector<double> D = alloc::strategy_score(s, in, placebo_seed);
    AdaptivePlan plan;
    plan.total = alloc::study_total(D.size(), extra_spp);
    plan.n = alloc::neyman_allocation(D, plan.total, floor, downstream_seeds::kPoolSize);
    plan.allocation_ms = 1000.0 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return plan;
}

}  // namespace vkmech
