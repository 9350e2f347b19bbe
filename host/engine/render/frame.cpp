#include "render/frame.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace vkmech {

void PixelStats::merge_moments(double n, double mean, double m2) {
    if (n <= 0.0) return;
    double total = count + n;
    double delta = mean - lum_mean;
    lum_mean += delta * n / total;
    lum_m2 += m2 + delta * delta * count * n / total;
    count = total;
}

double batch_lum_m2(const gpu::GpuPixelAccum& a) {
    return std::ldexp(static_cast<double>(a.lum.y), 2 * static_cast<int>(a.lum.w));
}

void Frame::merge(const std::vector<gpu::GpuPixelAccum>& batch) {
    for (size_t i = 0; i < pixels.size(); ++i) merge_pixel(i, batch[i]);
}

void Frame::merge(const std::vector<gpu::GpuPixelAccum>& batch, const uint32_t* only, size_t count) {
    for (size_t k = 0; k < count; ++k) merge_pixel(only[k], batch[only[k]]);
}

void Frame::merge_pixel(size_t i, const gpu::GpuPixelAccum& a) {
    PixelStats& p = pixels[i];
    for (int c = 0; c < 3; ++c) p.rgb_sum[c] += a.rgb[c];
    p.merge_moments(a.rgb.w, a.lum.x, batch_lum_m2(a));
    p.nonfinite += a.lum.z;
    double* rgb = bucket_rgb_sum.empty() ? nullptr : &bucket_rgb_sum[i * kBucketRgb];
    for (uint32_t b = 0; b < gpu::BUCKET_COUNT; ++b) {
        const double r = accum_bucket_rgb(a, b, 0), g = accum_bucket_rgb(a, b, 1), bl = accum_bucket_rgb(a, b, 2);
        p.bucket_sum[b] += luminance(r, g, bl);
        if (rgb) {
            rgb[3 * b] += r;
            rgb[3 * b + 1] += g;
            rgb[3 * b + 2] += bl;
        }
    }
    p.glossy_sum += a.side.x;
    p.depth_weighted_sum += a.side.y;
    p.depth_weight += a.side.z;
    if (!direct_glossy_sum.empty())  // the variant's; 0 otherwise
        direct_glossy_sum[i] += luminance(a.bucket_rgb[5].y, a.bucket_rgb[5].z, a.bucket_rgb[5].w);
}

void Frame::merge(const Frame& other) {
    if (other.width != width || other.height != height || other.pixels.size() != pixels.size())
        throw std::invalid_argument("Frame::merge: a " + std::to_string(other.width) + "x" +
                                    std::to_string(other.height) + " frame merged into a " + std::to_string(width) +
                                    "x" + std::to_string(height) + " one");
    for (size_t i = 0; i < pixels.size(); ++i) {
        PixelStats& x = pixels[i];
        const PixelStats& y = other.pixels[i];
        for (int k = 0; k < 3; ++k) x.rgb_sum[k] += y.rgb_sum[k];
        x.merge_moments(y.count, y.lum_mean, y.lum_m2);
        x.nonfinite += y.nonfinite;
        for (uint32_t b = 0; b < gpu::BUCKET_COUNT; ++b) x.bucket_sum[b] += y.bucket_sum[b];
        x.glossy_sum += y.glossy_sum;
        x.depth_weighted_sum += y.depth_weighted_sum;
        x.depth_weight += y.depth_weight;
    }
    if (other.direct_glossy_sum.size() == direct_glossy_sum.size())
        for (size_t i = 0; i < direct_glossy_sum.size(); ++i) direct_glossy_sum[i] += other.direct_glossy_sum[i];
    else
        direct_glossy_sum.clear();  // only one of the two has the split: the sum has none
    if (other.bucket_rgb_sum.size() == bucket_rgb_sum.size())
        for (size_t i = 0; i < bucket_rgb_sum.size(); ++i) bucket_rgb_sum[i] += other.bucket_rgb_sum[i];
    else
        bucket_rgb_sum.clear();
    samples += other.samples;
    seconds += other.seconds;
}

std::vector<float> Frame::rgb_mean() const {
    std::vector<float> out(pixels.size() * 3, 0.0f);
    for (size_t i = 0; i < pixels.size(); ++i) {
        // Mean over all samples taken, non-finite ones included as zero
        // contributions would bias; they are excluded and counted instead.
        double n = pixels[i].count;
        for (int c = 0; c < 3; ++c) out[3 * i + c] = n > 0 ? static_cast<float>(pixels[i].rgb_sum[c] / n) : 0.0f;
    }
    return out;
}

}  // namespace vkmech
