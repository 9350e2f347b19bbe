// One renderer call: render(scene, RenderSpec) -> Frame (docs/architecture.md, "One render"). Everything
// that runs many renders is host orchestration over this.
#pragma once

#include "render/features.hpp"
#include "render/frame.hpp"
#include "render/gpu_scene.hpp"
#include "vk/pipeline.hpp"

#include <array>
#include <functional>
#include <memory>
#include <optional>

namespace vkmech {

// Where a render's wall time goes, batch by batch (bench render --profile):
// host clock around each step of the batch loop. `dispatch` is submit + wait,
// so it holds the GPU's work (on lavapipe: the path tracing on the CPU).
struct RenderProfile {
    uint32_t batches = 0;
    double upload = 0.0;      // the batch's parameters to the device
    double dispatch = 0.0;    // record, submit, wait for the fence
    double readback = 0.0;    // the accumulation buffer to the host
    double accumulate = 0.0;  // Frame::merge: the batch into the frame's running moments (double)
    double callbacks = 0.0;   // on_batch and progress
};

// The software BVH's work over every render of a Renderer built with
// Features::counters (the instrumented shader), summed over its batches.
struct TraversalCounters {
    double rays = 0, nodes = 0, leaves = 0,
           triangles = 0;  // traces; interior nodes, leaves, triangles per trace summed
    uint32_t deepest_stack = 0;
    // Subgroup-clock ticks per phase (gpu::PHASE_*), summed over the invocations: an
    // invocation's ticks include the time its SIMD vector or warp spends on the other
    // invocations' work, so the shares, not the absolute ticks, are what compare.
    std::array<double, gpu::PHASE_COUNT> clock{};
    double clock_backwards = 0;  // intervals left out: their end read an earlier clock than their start
};

// How a dispatch's invocations find their pixels. Tiles: each workgroup
// renders one 8 x 8 tile, in an order spread over the image (GPUs schedule
// workgroups as they free up). Claimed: every invocation takes the next pixel
// slot from a counter until none is left (CPU devices: lavapipe hands each
// of its threads one contiguous range of workgroups up front, so a static
// assignment leaves threads idle at the end of every dispatch). Auto:
// claimed on CPU devices, tiles elsewhere. The images are the same bit for bit.
enum class PixelOrder { Auto, Tiles, Claimed };

struct RenderSpec {
    uint32_t spp = 64;
    uint32_t seed = 0;
    // The first sample of the seed's stream: the render takes samples [first_sample, first_sample + spp)
    // (render --sample-range; sample i of a seed is the same whatever the batch, so disjoint ranges
    // merge into the single render). With per-pixel sample_counts: samples [first_sample, n(p)).
    uint32_t first_sample = 0;
    // A window of the film, [x0, x1) x [y0, y1) (render --pixel-bounds): the frame is the window's,
    // its pixels' rays and random streams the full film's. Needs Features::window.
    std::optional<PixelBounds> window;
    uint32_t batch_spp = 8;  // samples per dispatch
    // With per-pixel sample_counts: when only a share s of the film's pixels still takes samples, a
    // dispatch takes up to batch_spp / s samples, at most this many (about a whole film's batch of
    // work; 0 or at most batch_spp: batch_spp always). Fewer dispatches, each read back whole.
    uint32_t max_batch_spp = 0;
    uint32_t mode = gpu::MODE_PATH;
    // Adaptive rendering (docs/descriptor.md §6): when non-empty (one entry per pixel), pixel p
    // takes exactly samples [first_sample, n(p)) of `seed` (none where n(p) <= first_sample) and
    // `spp` is ignored. One entry per pixel is the
    // caller's to ensure (the Python binding checks the array's shape); else InternalError.
    std::vector<uint32_t> sample_counts;
    // Called after each batch with (samples done, samples total).
    std::function<void(uint32_t, uint32_t)> progress;
    // Called with each batch's raw per-pixel moments (tests, per-frame studies).
    std::function<void(const std::vector<gpu::GpuPixelAccum>&)> on_batch;
    // Called after each batch with the frame so far (its seconds and samples not yet set): a live view.
    std::function<void(const Frame&)> on_frame;
    // When set, filled with the time of each step of the batch loop (summed over batches).
    RenderProfile* profile = nullptr;
    PixelOrder pixel_order = PixelOrder::Auto;
};

struct SceneOnDevice;  // render/session.hpp

// Made by RenderSession::renderer; shares the session's scene, so it stays
// valid on its own (only the vk::Context must outlive it).
class Renderer {
public:
    Renderer(std::shared_ptr<const SceneOnDevice> scene, const Features& features);
    const Features& features() const { return features_; }
    Frame render(const RenderSpec& spec);
    // With Features::debug_events: renders `spec` and returns the contribution
    // events of one pixel (at most `capacity`), in no particular order.
    std::vector<gpu::GpuDebugEvent> render_debug_events(const RenderSpec& spec, uint32_t pixel, uint32_t capacity,
                                                        Frame* frame = nullptr);
    // With Features::counters: the traversal's work of every render so far.
    const TraversalCounters& counters() const { return counters_; }

private:
    std::shared_ptr<const SceneOnDevice> on_device_;
    const vk::Context& ctx_;
    const Scene& scene_;
    const SceneArrays& arrays_;
    const GpuScene& gpu_;
    Features features_;
    std::unique_ptr<vk::ComputePipeline> pipeline_;
    vk::Buffer params_, accum_, debug_, sample_counts_, counter_buffer_, work_, taxonomy_;
    TraversalCounters counters_;
    uint32_t debug_pixel_ = 0, debug_capacity_ = 0;
};

// The path tracer's workgroup order (pathtrace.comp): the workgroup with
// index w of a dispatch of n renders tile w * stride mod n. The stride is
// coprime with n, so the order is a permutation, and near n times the golden
// ratio's conjugate, so any contiguous range of indices (what each lavapipe
// thread gets) is spread over the whole image. n is 1 to 2^24 (the shader's
// modular product needs n <= 2^24; films are at most 2^15 pixels a side, in
// 8 x 8 tiles): else InternalError.
uint32_t workgroup_stride(uint64_t n);

// Camera parameters of Params: tan of the half field of view on x and y.
glm::vec2 camera_tangents(const Camera& camera);

}  // namespace vkmech
