#include "study/separation_gpu.hpp"

#include "render/ray_caster.hpp"

#include <stdexcept>
#include <string>

namespace vkmech {

SeparationMeasures measure_separation(const vk::Context& ctx, const Scene& scene, const SceneArrays& arrays,
                                      const GpuScene& gpu, uint32_t points_per_object, uint32_t seed, float offset) {
    if (arrays.triangle_mesh.size() != scene.triangle_count())
        throw std::invalid_argument("measure_separation: the scene arrays (" + std::to_string(arrays.triangle_mesh.size()) +
                                    " triangles) do not belong to the scene (" + std::to_string(scene.triangle_count()) +
                                    " triangles)");
    RayCaster caster(ctx, gpu);
    auto unoccluded = [&](const std::vector<gpu::GpuRay>& rays) {
        std::vector<gpu::GpuHit> hits = caster.trace(rays, /*any_hit=*/true);
        std::vector<uint8_t> open(hits.size());
        for (size_t i = 0; i < hits.size(); ++i) open[i] = hits[i].hit.x > 0.0f ? 0 : 1;
        return open;
    };
    return measure_separation(scene, unoccluded, points_per_object, seed, offset);
}

SeparationMeasures measure_separation(const RenderSession& session, uint32_t points_per_object, uint32_t seed,
                                      float offset) {
    return measure_separation(session.context(), session.scene(), session.arrays(), session.gpu(), points_per_object,
                              seed, offset);
}

}  // namespace vkmech
