#include "study/separation_gpu.hpp"

#include "render/ray_caster.hpp"

namespace vkmech {

SeparationMeasures measure_separation(const RenderSession& session, uint32_t points_per_object, uint32_t seed,
                                      float offset) {
    RayCaster caster(session.context(), session.gpu());
    auto unoccluded = [&](const std::vector<gpu::GpuRay>& rays) {
        std::vector<gpu::GpuHit> hits = caster.trace(rays, /*any_hit=*/true);
        std::vector<uint8_t> open(hits.size());
        for (size_t i = 0; i < hits.size(); ++i) open[i] = hits[i].hit.x > 0.0f ? 0 : 1;
        return open;
    };
    return measure_separation(session.scene(), unoccluded, points_per_object, seed, offset);
}

}  // namespace vkmech
