// The separation measures of experiments/separation.hpp with their segments
// traced on the device (RayCaster over the GpuScene's traversal): the GPU work
// that the separation analysis needs, handed in from the app layer.
#pragma once

#include "experiments/separation.hpp"
#include "render/gpu_scene.hpp"
#include "render/session.hpp"
#include "vk/context.hpp"

namespace vkmech {

// `arrays` must be flatten_scene(scene) and `gpu` built from it (any
// traversal). Throws std::invalid_argument when arrays and scene disagree.
SeparationMeasures measure_separation(const vk::Context& ctx, const Scene& scene, const SceneArrays& arrays,
                                      const GpuScene& gpu, uint32_t points_per_object = 64, uint32_t seed = 0,
                                      float offset = 1e-3f);
// The same over a session's scene and traversal.
SeparationMeasures measure_separation(const RenderSession& session, uint32_t points_per_object = 64, uint32_t seed = 0,
                                      float offset = 1e-3f);

}  // namespace vkmech
