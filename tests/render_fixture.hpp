// Renders a scene on the test device with one call, for the estimator tests.
#pragma once

#include "render/descriptor.hpp"
#include "render/features.hpp"
#include "render/gpu_scene.hpp"
#include "render/renderer.hpp"
#include "scene/scene.hpp"
#include "vk/context.hpp"

#include <functional>

namespace vkmech::testing {

struct RenderSetup {
    int res = 32;  // film width (height by aspect)
    uint32_t spp = 16;
    uint32_t seed = 0;
    uint32_t batch = 8;
    Traversal traversal = Traversal::Bvh;
    Estimator estimator = Estimator::Nee;
    bool generic = false;
    LoadOptions load;
    std::function<void(const std::vector<gpu::GpuPixelAccum>&)> on_batch;
    std::vector<uint32_t> sample_counts;  // adaptive: n(p) per pixel (docs/descriptor.md §6)
    PixelOrder pixel_order = PixelOrder::Auto;
    vk::KernelClass kernel = vk::KernelClass::Auto;  // the context's
    // Ray query on the arrays the software BVH renders (its triangle order, so
    // its light table and sample streams) instead of the scene's own order.
    bool bvh_arrays = false;
};

// Per pixel its RGB sum and its seven buckets' energies, in pixel order.
std::vector<double> pixel_values(const Frame& f);
// The largest |a_i - b_i| / (|b_i| + 1e-3) (a and b of one size).
double max_relative_difference(const std::vector<double>& a, const std::vector<double>& b);

Frame render_scene(vk::Context& ctx, const std::string& path, const RenderSetup& setup);
// The same for a scene already loaded (and perhaps changed by the test).
Frame render_scene(vk::Context& ctx, Scene scene, const RenderSetup& setup);

// A renderer (the scene's own features, BVH traversal) for the project scene
// scenes/<name>.xml at film width `width`, for tests that render several times
// (pilots, references) on one scene.
Renderer project_scene_renderer(vk::Context& ctx, const std::string& name, int width);

}  // namespace vkmech::testing
