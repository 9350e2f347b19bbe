#include "render/renderer.hpp"
#include "io/invariant.hpp"

#include "render/session.hpp"
#include "render/shader_modules.hpp"
#include "shared/bindings.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <numeric>
#include <optional>
#include <stdexcept>

#include <unistd.h>

namespace vkmech {

namespace {

// The counters buffer: the traversal's work, then 64-bit clock ticks per phase (shared/types.h).
constexpr uint32_t kCounterWords = gpu::COUNTER_CLOCK + 2 * gpu::PHASE_COUNT;

// The pipeline specialization of one Features value.
std::vector<vk::SpecConstant> spec_constants(const Features& f, bool instanced) {
    using namespace gpu;
    std::vector<vk::SpecConstant> c = {{SPEC_THIN_LENS, f.thin_lens},
                                       {SPEC_TEXTURES, f.textures},
                                       {SPEC_CAPTURE, f.capture},
                                       {SPEC_ESTIMATOR, static_cast<uint32_t>(f.estimator)},
                                       {SPEC_DEBUG_EVENTS, f.debug_events},
                                       {SPEC_END_VERTEX_LITERAL, f.end_vertex == EndVertex::Literal},
                                       {SPEC_ORTHOGRAPHIC, f.orthographic},
                                       {SPEC_ENVIRONMENT, f.environment},
                                       {SPEC_SHARED_TALLY, gpu_tally_from_env() == GpuTally::Shared},
                                       {SPEC_INSTANCES, instanced},
                                       {SPEC_WINDOW, f.window},
                                       {SPEC_TANGENTS, f.tangents},
                                       {SPEC_TAXONOMY, !f.taxonomy.empty()}};
#define VKM_X(NAME, name, bit, spec_id) c.push_back({SPEC_##NAME, (f.materials & FEATURE_BIT_##NAME) != 0u});
    VKM_MATERIAL_FEATURES(VKM_X)
#undef VKM_X
    return c;
}

// docs/reliability.md: what a film costs, said before (or instead of) a raw allocation failure.
uint64_t film_device_bytes(uint64_t pixels) { return pixels * (sizeof(gpu::GpuPixelAccum) + 2 * sizeof(uint32_t)); }
uint64_t film_host_bytes(uint64_t pixels) {
    return pixels * (sizeof(PixelStats) + Frame::kBucketRgb * sizeof(double) + sizeof(gpu::GpuPixelAccum));
}

[[noreturn]] void film_out_of_memory(const Camera& cam, const std::string& why) {
    const uint64_t px = static_cast<uint64_t>(cam.width) * static_cast<uint64_t>(cam.height);
    throw vk::OutOfMemoryError("a " + std::to_string(cam.width) + "x" + std::to_string(cam.height) + " film needs " +
                                   vk::byte_size_text(film_device_bytes(px)) +
                                   " of device memory (accumulation and sample-count buffers) and " +
                                   vk::byte_size_text(film_host_bytes(px)) +
                                   " of host memory (the frame and its "
                                   "readback); " +
                                   why + "; lower --res",
                               film_device_bytes(px));
}

// VKMECH_MEMORY_LIMIT: a cap on the film's device and host memory, in bytes
// or with a K/M/G/T(i)B suffix, so that a refusal does not depend on the
// machine's size (the tests set it). Unset or empty: no cap.
std::optional<uint64_t> memory_limit_bytes() {
    const char* env = std::getenv("VKMECH_MEMORY_LIMIT");
    if (!env || !*env) return std::nullopt;
    const std::string text(env);
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(env, &end);
    std::string unit(end);
    unit.erase(0, unit.find_first_not_of(' '));
    for (auto& c : unit) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    double scale = 0.0;
    if (unit.empty() || unit == "B") scale = 1.0;
    if (unit == "K" || unit == "KB" || unit == "KIB") scale = 0x1p10;
    if (unit == "M" || unit == "MB" || unit == "MIB") scale = 0x1p20;
    if (unit == "G" || unit == "GB" || unit == "GIB") scale = 0x1p30;
    if (unit == "T" || unit == "TB" || unit == "TIB") scale = 0x1p40;
    if (end == env || errno != 0 || scale == 0.0 || !(value > 0.0) || value * scale > 0x1p63)
        throw std::invalid_argument("VKMECH_MEMORY_LIMIT='" + text +
                                    "': expected a positive size such as 4GiB, 512MiB or 1073741824 (bytes)");
    return static_cast<uint64_t>(value * scale);
}

uint64_t physical_ram_bytes() {
    long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
    return pages > 0 && page > 0 ? static_cast<uint64_t>(pages) * static_cast<uint64_t>(page) : 0;
}

}  // namespace

uint32_t workgroup_stride(uint64_t n) {
    VKM_ASSERT(n != 0 && n <= (uint64_t{1} << 24),
               "workgroup order: " + std::to_string(n) + " workgroups (1 to 2^24 supported)");
    uint64_t stride = static_cast<uint64_t>(std::llround(static_cast<double>(n) * 0.6180339887498949)) % n;
    while (std::gcd(stride, n) != 1) stride = (stride + 1) % n;  // gcd(0, 1) = 1 ends n = 1
    return static_cast<uint32_t>(stride);
}

glm::vec2 camera_tangents(const Camera& cam) {
    float t = std::tan(glm::radians(cam.fov_deg) * 0.5f);
    float w = static_cast<float>(cam.width), h = static_cast<float>(cam.height);
    if (cam.type == CameraType::Orthographic) return {1.0f, h / w};  // half extents in camera space
    std::string axis = cam.fov_axis;
    if (axis == "smaller") axis = w <= h ? "x" : "y";
    if (axis == "larger") axis = w >= h ? "x" : "y";
    if (axis == "y") return {t * w / h, t};
    if (axis == "diagonal") {
        float d = std::sqrt(w * w + h * h);
        return {t * w / d, t * h / d};
    }
    return {t, t * h / w};
}

Renderer::Renderer(std::shared_ptr<const SceneOnDevice> on_device, const Features& features)
    : on_device_(std::move(on_device)),
      ctx_(on_device_->ctx),
      scene_(on_device_->scene),
      arrays_(on_device_->arrays),
      gpu_(on_device_->gpu),
      features_(features) {
    const vk::Context& ctx = ctx_;
    const Scene& scene = scene_;
    // The projection is the camera's, whatever pipeline was asked for.
    features_.orthographic = scene.camera.type == CameraType::Orthographic;
    using DT = ::vk::DescriptorType;
    using namespace gpu;
    std::vector<vk::BindingDesc> bindings = {
        {BINDING_PARAMS, DT::eUniformBuffer},   {BINDING_ACCUM, DT::eStorageBuffer},
        {BINDING_DEBUG, DT::eStorageBuffer},    {BINDING_SAMPLE_COUNTS, DT::eStorageBuffer},
        {BINDING_COUNTERS, DT::eStorageBuffer}, {BINDING_WORK, DT::eStorageBuffer},
        {BINDING_TAXONOMY, DT::eStorageBuffer}};
    for (const auto& b : scene_bindings(gpu_.traversal(), gpu_.kernel())) bindings.push_back(b);
    VKM_ASSERT(!features_.direct_glossy || features_.capture,
               "the direct_glossy output needs the mechanism capture on (the CLI refuses it without)");
    VKM_ASSERT(features_.taxonomy.empty() || (features_.capture && !features_.direct_glossy),
               "a taxonomy needs the capture on and the direct_glossy output off (the CLI refuses them)");
    if (features_.counters && !ctx.shader_clock_enabled())
        throw std::invalid_argument(
            "the path tracer's counters time its phases with VK_KHR_shader_clock's subgroup "
            "clock, which " +
            ctx.info().name + " does not have");
    // The direct-glossy variant is another SPIR-V module, so another pipeline (and pipeline-cache entry).
    pipeline_ = std::make_unique<vk::ComputePipeline>(
        ctx, pathtrace_spirv(gpu_.traversal(), gpu_.kernel(), features_.direct_glossy, features_.counters), bindings, 0,
        spec_constants(features_, gpu_.instanced()));
    size_t pixels = static_cast<size_t>(scene.camera.width) * scene.camera.height;
    // The limit first: the same refusal on every machine.
    if (const auto limit = memory_limit_bytes();
        limit && (film_device_bytes(pixels) > *limit || film_host_bytes(pixels) > *limit))
        film_out_of_memory(scene.camera, "VKMECH_MEMORY_LIMIT allows " + vk::byte_size_text(*limit));
    if (const uint64_t heap = ctx.info().device_local_bytes; heap > 0 && film_device_bytes(pixels) > heap)
        film_out_of_memory(scene.camera, "the device's largest memory heap has " + vk::byte_size_text(heap));
    if (const uint64_t ram = physical_ram_bytes(); ram > 0 && film_host_bytes(pixels) > ram)
        film_out_of_memory(scene.camera, "this machine has " + vk::byte_size_text(ram) + " of RAM");
    params_ = vk::Buffer(ctx, sizeof(gpu::GpuParams), ::vk::BufferUsageFlagBits::eUniformBuffer, vk::MemoryUse::Upload);
    try {
        accum_ = vk::Buffer(ctx, pixels * sizeof(gpu::GpuPixelAccum), ::vk::BufferUsageFlagBits::eStorageBuffer,
                            vk::MemoryUse::Readback);
        sample_counts_ = vk::Buffer(ctx, 2 * pixels * sizeof(uint32_t), ::vk::BufferUsageFlagBits::eStorageBuffer,
                                    vk::MemoryUse::Upload);
    } catch (const vk::OutOfMemoryError& e) {
        film_out_of_memory(scene.camera, std::string("allocating failed: ") + e.what());
    }
    pipeline_->bind_buffer(BINDING_PARAMS, params_.handle());
    pipeline_->bind_buffer(BINDING_ACCUM, accum_.handle());
    gpu_.bind_scene(*pipeline_);
    // The debug buffer: a counter (16 bytes) then the events; minimal when off.
    debug_ = vk::Buffer(ctx, 16 + sizeof(gpu::GpuDebugEvent) * (features_.debug_events ? 65536 : 1),
                        ::vk::BufferUsageFlagBits::eStorageBuffer, vk::MemoryUse::Readback);
    pipeline_->bind_buffer(BINDING_DEBUG, debug_.handle());
    pipeline_->bind_buffer(BINDING_SAMPLE_COUNTS, sample_counts_.handle());
    // The counters variant's totals (kCounterWords uints, zeroed before each batch); bound always, written by it only.
    counter_buffer_ = vk::Buffer(ctx, kCounterWords * sizeof(uint32_t), ::vk::BufferUsageFlagBits::eStorageBuffer,
                                 vk::MemoryUse::Readback);
    pipeline_->bind_buffer(BINDING_COUNTERS, counter_buffer_.handle());
    // Claimed pixels' slot counter (zeroed before each batch that uses it).
    work_ = vk::Buffer(ctx, 16, ::vk::BufferUsageFlagBits::eStorageBuffer, vk::MemoryUse::Upload);
    pipeline_->bind_buffer(BINDING_WORK, work_.handle());
    // A user taxonomy's DFA (docs/lpe.md); bound always, read only under SPEC_TAXONOMY.
    const std::vector<uint32_t> no_taxonomy(gpu::TAX_HEADER_WORDS, 0u);
    taxonomy_ = vk::Buffer::from_vector(ctx, features_.taxonomy.empty() ? no_taxonomy : features_.taxonomy,
                                        ::vk::BufferUsageFlagBits::eStorageBuffer);
    pipeline_->bind_buffer(BINDING_TAXONOMY, taxonomy_.handle());
    // Compile now (lavapipe compiles at the first dispatch), so that a
    // Frame's seconds count rendering only.
    pipeline_->warm_up();
}

Frame Renderer::render(const RenderSpec& spec) {
    const Camera& cam = scene_.camera;
    Frame frame;
    // The film: the camera's, or the window of it that spec.window names.
    VKM_ASSERT(spec.window.has_value() == features_.window,
               "a window render needs a renderer made with Features::window, and only it");
    uint32_t film_w = static_cast<uint32_t>(cam.width), film_h = static_cast<uint32_t>(cam.height);
    if (spec.window) {
        const PixelBounds& w = *spec.window;
        VKM_ASSERT(w.x0 < w.x1 && w.x1 <= film_w && w.y0 < w.y1 && w.y1 <= film_h, "the window lies outside the film");
        film_w = w.x1 - w.x0;
        film_h = w.y1 - w.y0;
    }
    frame.width = static_cast<int>(film_w);
    frame.height = static_cast<int>(film_h);
    size_t pixels = static_cast<size_t>(film_w) * film_h;
    std::vector<gpu::GpuPixelAccum> batch;
    try {
        frame.pixels.assign(pixels, PixelStats{});
        if (features_.direct_glossy) frame.direct_glossy_sum.assign(pixels, 0.0);
        if (features_.capture) frame.bucket_rgb_sum.assign(pixels * Frame::kBucketRgb, 0.0);
        batch.resize(pixels);
    } catch (const std::bad_alloc&) {
        film_out_of_memory(cam, "the host could not allocate it");
    }

    gpu::GpuParams p{};
    p.camera_to_world = cam.to_world;
    glm::vec2 tans = camera_tangents(cam);
    p.tan_half_fov_x = tans.x;
    p.tan_half_fov_y = tans.y;
    p.aperture_radius = cam.type == CameraType::ThinLens ? cam.aperture_radius : 0.0f;
    p.focus_distance = cam.focus_distance;
    p.near_clip = cam.near_clip;
    p.far_clip = cam.far_clip;
    p.film_width = film_w;
    p.film_height = film_h;
    if (spec.window) {
        p.window_x0 = spec.window->x0;
        p.window_y0 = spec.window->y0;
        p.full_width = static_cast<uint32_t>(cam.width);
        p.full_height = static_cast<uint32_t>(cam.height);
    }
    p.seed = spec.seed;
    p.max_depth = scene_.integrator.max_depth;
    p.rr_depth = scene_.integrator.rr_depth;
    p.mode = spec.mode;
    p.light_triangle_count = static_cast<uint32_t>(arrays_.light_triangles.size());
    p.tangent_word_offset = arrays_.tangent_word_offset();
    p.debug_pixel = debug_pixel_;
    p.debug_capacity = debug_capacity_;

    // Adaptive: n(p) samples at each pixel, samples [0, n(p)) of the seed (docs/descriptor.md §6).
    std::vector<uint32_t> order;
    uint32_t total_spp = spec.spp;
    uint64_t total_samples = static_cast<uint64_t>(spec.spp) * pixels;
    if (!spec.sample_counts.empty()) {
        VKM_ASSERT(spec.sample_counts.size() == pixels,
                   "per-pixel sample counts: " + std::to_string(spec.sample_counts.size()) + " entries for " +
                       std::to_string(pixels) + " pixels");
        // Counts, then the pixels sorted by count (largest first, ties by index): each batch
        // is dispatched over the prefix that still needs samples.
        order.resize(pixels);
        for (size_t i = 0; i < pixels; ++i) order[i] = static_cast<uint32_t>(i);
        std::stable_sort(order.begin(), order.end(),
                         [&](uint32_t a, uint32_t b) { return spec.sample_counts[a] > spec.sample_counts[b]; });
        std::vector<uint32_t> buffer(spec.sample_counts);
        buffer.insert(buffer.end(), order.begin(), order.end());
        sample_counts_.upload(ctx_, buffer.data(), buffer.size() * sizeof(uint32_t));
        p.per_pixel_counts = 1u;
        // Pixel p takes samples [first_sample, n(p)): none where n(p) <= first_sample.
        const uint32_t end = *std::max_element(spec.sample_counts.begin(), spec.sample_counts.end());
        total_spp = end > spec.first_sample ? end - spec.first_sample : 0u;
        total_samples = 0;
        for (uint32_t n : spec.sample_counts) total_samples += n > spec.first_sample ? n - spec.first_sample : 0u;
    }

    auto t0 = std::chrono::steady_clock::now();
    // The CPU kernel claims pixels and spreads its tiles (lavapipe's threads);
    // the GPU kernel dispatches 8 x 8 tiles in image order (docs/gpu.md).
    const bool cpu_kernel = gpu_.kernel() == vk::KernelClass::Cpu;
    const bool claimed =
        spec.pixel_order == PixelOrder::Claimed || (spec.pixel_order == PixelOrder::Auto && cpu_kernel);
    p.claimed_pixels = claimed ? 1u : 0u;
    uint32_t batch_spp = std::max(1u, spec.batch_spp);
    // Samples [first, first + spp) of the seed's stream (render --sample-range).
    const uint32_t first = spec.first_sample;
    VKM_ASSERT(total_spp <= UINT32_MAX - first, "the sample range ends past 2^32");
    for (uint32_t done = first; done < first + total_spp;) {
        size_t active = pixels;
        uint32_t dispatch_spp = batch_spp;
        if (!order.empty()) {  // the pixels with n(p) > done form a prefix of `order`
            active =
                static_cast<size_t>(std::partition_point(order.begin(), order.end(),
                                                         [&](uint32_t q) { return spec.sample_counts[q] > done; }) -
                                    order.begin());
            p.active_pixels = static_cast<uint32_t>(active);
            // Few pixels left: more samples per dispatch, about a whole film's batch of work each.
            if (spec.max_batch_spp > batch_spp && active > 0)
                dispatch_spp = static_cast<uint32_t>(std::clamp<uint64_t>(
                    static_cast<uint64_t>(batch_spp) * pixels / active, batch_spp, spec.max_batch_spp));
        }
        uint32_t n = std::min(dispatch_spp, first + total_spp - done);
        p.batch_samples = n;
        p.first_sample = done;
        using clk = std::chrono::steady_clock;
        auto t_phase = clk::now();
        auto lap = [&](double RenderProfile::*slot) {  // adds the time since the last lap to the profile's slot
            if (!spec.profile) return;
            const auto now = clk::now();
            spec.profile->*slot += std::chrono::duration<double>(now - t_phase).count();
            t_phase = now;
        };
        uint32_t gx = (film_w + 7) / 8, gy = (film_h + 7) / 8;
        if (!order.empty()) {
            uint32_t groups = static_cast<uint32_t>((active + 63) / 64);
            gx = std::min(groups, 65535u);  // the guaranteed maxComputeWorkGroupCount
            gy = (groups + gx - 1) / gx;
        }
        if (claimed) {
            // Enough workgroups for every thread of the device to claim slots; the
            // first to start on each thread takes slots until none is left.
            gx = static_cast<uint32_t>(std::min<uint64_t>(static_cast<uint64_t>(gx) * gy, 256));
            gy = 1;
            const uint32_t zero[4] = {};
            work_.upload(ctx_, zero, sizeof(zero));
        } else {
            p.workgroup_stride = cpu_kernel ? workgroup_stride(static_cast<uint64_t>(gx) * gy) : 1u;
        }
        params_.upload(ctx_, &p, sizeof(p));
        if (features_.counters) {
            const uint32_t zeros[kCounterWords] = {};
            counter_buffer_.upload(ctx_, zeros, sizeof(zeros));
        }
        lap(&RenderProfile::upload);
        ctx_.submit_and_wait([&](::vk::CommandBuffer cmd) { pipeline_->record(cmd, gx, gy, 1); });
        lap(&RenderProfile::dispatch);
        if (features_.counters) {
            uint32_t c[kCounterWords];
            counter_buffer_.download(ctx_, c, sizeof(c));
            if (c[gpu::COUNTER_WRAPPED] != 0)
                throw std::runtime_error(
                    "traversal counters: a 32-bit total overflowed in one batch; render the "
                    "counters with fewer samples per batch or a smaller film");
            counters_.rays += c[gpu::COUNTER_RAYS];
            counters_.nodes += c[gpu::COUNTER_NODES];
            counters_.leaves += c[gpu::COUNTER_LEAVES];
            counters_.triangles += c[gpu::COUNTER_TRIANGLES];
            counters_.deepest_stack = std::max(counters_.deepest_stack, c[gpu::COUNTER_DEEPEST_STACK]);
            counters_.clock_backwards += c[gpu::COUNTER_CLOCK_BACKWARDS];
            for (uint32_t p = 0; p < gpu::PHASE_COUNT; ++p)
                counters_.clock[p] += static_cast<double>(c[gpu::COUNTER_CLOCK + 2 * p]) +
                                      static_cast<double>(c[gpu::COUNTER_CLOCK + 2 * p + 1]) * 0x1p32;
        }
        accum_.download(ctx_, batch.data(), batch.size() * sizeof(gpu::GpuPixelAccum));
        lap(&RenderProfile::readback);
        if (order.empty()) {
            frame.merge(batch);
        } else {
            // Pixels outside the active prefix were not written in this batch: they took no samples.
            frame.merge(batch, order.data(), active);
            if (spec.on_batch)
                for (size_t i = active; i < order.size(); ++i) batch[order[i]] = gpu::GpuPixelAccum{};
        }
        lap(&RenderProfile::accumulate);
        if (spec.on_batch) spec.on_batch(batch);
        if (spec.on_frame) spec.on_frame(frame);
        done += n;
        if (spec.progress) spec.progress(done - first, total_spp);
        lap(&RenderProfile::callbacks);
        if (spec.profile) spec.profile->batches += 1;
    }
    frame.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    frame.samples = total_samples;
    return frame;
}

std::vector<gpu::GpuDebugEvent> Renderer::render_debug_events(const RenderSpec& spec, uint32_t pixel, uint32_t capacity,
                                                              Frame* frame) {
    VKM_ASSERT(features_.debug_events, "render_debug_events needs a renderer made with Features::debug_events");
    capacity = std::min<uint32_t>(capacity, 65536);
    uint32_t zero[4] = {0, 0, 0, 0};
    debug_.upload(ctx_, zero, sizeof(zero));
    debug_pixel_ = pixel;
    debug_capacity_ = capacity;
    Frame f = render(spec);
    debug_capacity_ = 0;
    uint32_t count = 0;
    debug_.download(ctx_, &count, sizeof(count));
    std::vector<gpu::GpuDebugEvent> events(std::min(count, capacity));
    debug_.download(ctx_, events.data(), events.size() * sizeof(gpu::GpuDebugEvent), 16);
    if (frame) *frame = std::move(f);
    return events;
}

}  // namespace vkmech
