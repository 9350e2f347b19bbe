#include "adaptive/adaptive.hpp"

#include <stdexcept>
#include <utility>

namespace vkmech {

Pilot render_pilot(Renderer& r, uint32_t n0, uint32_t seed, bool robust) {
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
    Frame frame = r.render(spec);  // fills `blocks` through on_batch: render first, then the MoM
    return make_pilot(std::move(frame), robust ? alloc::mom_variance(blocks) : std::vector<double>{});
}

}  // namespace vkmech
