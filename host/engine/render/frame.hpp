// A finished render: per-pixel sums and moments in double, merged across
// batches with Chan's parallel update (docs/architecture.md, "Stable numerics").
#pragma once

#include "shared/types.h"

#include <array>
#include <cstdint>
#include <vector>

namespace vkmech {

struct PixelStats {
    double count = 0.0;  // finite samples
    double nonfinite = 0.0;
    std::array<double, 3> rgb_sum{};
    double lum_mean = 0.0;
    double lum_m2 = 0.0;  // sum of squared deviations
    std::array<double, gpu::BUCKET_COUNT> bucket_sum{};
    double glossy_sum = 0.0;
    double depth_weighted_sum = 0.0;
    double depth_weight = 0.0;

    // Chan et al.: merge a batch of n samples with mean m and M2.
    void merge_moments(double n, double mean, double m2);
    double lum_var() const { return count > 1.0 ? lum_m2 / (count - 1.0) : 0.0; }  // ddof 1
};

// A batch's M2 of luminance, in double: the shader stores it scaled by a
// power of two (lum.y * 4^lum.w, shaders/pathtrace.comp) so that it neither
// overflows nor underflows float.
double batch_lum_m2(const gpu::GpuPixelAccum& a);

// Channel c (0 = R, 1 = G, 2 = B) of bucket b's RGB sum in a batch's accumulator.
inline float accum_bucket_rgb(const gpu::GpuPixelAccum& a, uint32_t b, int c) {
    const uint32_t k = 3 * b + static_cast<uint32_t>(c);
    return a.bucket_rgb[k / 4][static_cast<int>(k % 4)];
}

// Rec. 709 luminance, the energy of the descriptor (docs/descriptor.md §3); the shader's
// luminance() uses the same weights (shared/types.h).
inline double luminance(double r, double g, double b) { return gpu::LUM_R * r + gpu::LUM_G * g + gpu::LUM_B * b; }

// A window of a film, [x0, x1) x [y0, y1): what `render --pixel-bounds x0,x1,y0,y1` renders
// (RenderSpec::window) and its outputs record (Provenance::pixel_bounds).
struct PixelBounds {
    uint32_t x0 = 0, x1 = 0, y0 = 0, y1 = 0;
};

struct Frame {
    int width = 0, height = 0;
    std::vector<PixelStats> pixels;
    double seconds = 0.0;  // wall time of the GPU work
    uint64_t samples = 0;  // samples taken (spp * pixels)
    // `render --extra-output direct_glossy` (docs/descriptor.md §3.4): per pixel, the energy sum of the
    // `direct` bucket's events whose end vertex is glossy (at most bucket_sum[BUCKET_DIRECT]).
    // Empty unless the renderer ran the direct-glossy variant; kept apart from PixelStats so that
    // the render cache's per-pixel format does not change (the cache does not store it).
    std::vector<double> direct_glossy_sum;
    // Per pixel, the linear RGB sums of the seven buckets: 3 * BUCKET_COUNT doubles, bucket b's
    // channel c at 3b + c (docs/descriptor.md §3: they add up to rgb_sum). PixelStats::bucket_sum is
    // their luminance. Filled whenever the mechanism capture is on; kept apart from PixelStats,
    // which the render cache stores as it is (studies need the luminance only).
    std::vector<double> bucket_rgb_sum;
    static constexpr size_t kBucketRgb = 3 * gpu::BUCKET_COUNT;

    void merge(const std::vector<gpu::GpuPixelAccum>& batch);
    // The same for the `count` pixels listed in `only` (the others took no samples in the batch).
    void merge(const std::vector<gpu::GpuPixelAccum>& batch, const uint32_t* only, size_t count);
    // Another render of the same film on disjoint samples (e.g. a chunk of a
    // reference): sums added, moments merged with Chan's update, samples and
    // seconds added. Throws std::invalid_argument when the films differ. The direct-glossy
    // sums and the buckets' RGB sums are each added when both frames have them and dropped otherwise.
    void merge(const Frame& other);
    std::vector<float> rgb_mean() const;  // 3 per pixel

private:
    void merge_pixel(size_t i, const gpu::GpuPixelAccum& a);
};

}  // namespace vkmech
