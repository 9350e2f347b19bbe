#include "adaptive/adaptive.hpp"

#include <algorithm>
#include <stdexcept>
#include <utility>

namespace vkmech {

Pilot render_pilot(Renderer& r, uint32_t n0, uint32_t seed, bool robust,
                   const std::function<void(uint32_t, uint32_t)>& progress) {
    RenderSpec spec;
    spec.spp = n0;
    spec.seed = seed;
    spec.batch_spp = 8;
    spec.progress = progress;
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
    Frame frame = r.render(spec);  // fills `blocks` through on_batch: render first, then the MoM
    return make_pilot(std::move(frame), robust ? alloc::mom_variance(blocks) : std::vector<double>{});
}

AdaptivePlan plan_from_pilot(alloc::Strategy s, const Pilot& pilot, const alloc::PilotDiagnosis& diag, uint32_t n0,
                             uint32_t extra_spp, uint32_t floor, uint32_t pilot_draw,
                             const alloc::ClassTraits& traits) {
    alloc::ScoreInputs in;
    in.heavy = traits.heavy;
    in.rare = traits.rare;
    in.pilot_var = &pilot.var;
    in.pilot_labels = &pilot.labels;
    if (alloc::needs_mom(s)) in.mom_var = &pilot.mom_var;
    in.untrusted = &diag.untrusted_map;
    in.pilot_spp = n0;
    return plan_allocation(s, in, extra_spp, floor, pilot_draw);
}

alloc::ClassTraits class_traits(const SceneTaxonomy* taxonomy) {
    alloc::ClassTraits t;
    if (taxonomy) {
        t.heavy = taxonomy->heavy_classes();
        t.constant = taxonomy->constant_classes();
        t.rare = taxonomy->rare_classes();
    }
    return t;
}

std::string adaptive_sample_range(const std::vector<uint32_t>& n) {
    const uint32_t max_n = n.empty() ? 0u : *std::max_element(n.begin(), n.end());
    return "0:" + std::to_string(max_n) + " (adaptive: samples 0:n(p) at pixel p, n(p) in the spp channel)";
}

RenderSpec adaptive_render_spec(const AdaptivePlan& plan, uint32_t batch_spp) {
    RenderSpec spec;
    spec.seed = downstream_seeds::kPool;
    spec.batch_spp = batch_spp;
    spec.sample_counts = plan.n;
    return spec;
}

}  // namespace vkmech
