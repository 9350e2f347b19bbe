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
    for (size_t i = 0; i < pixels.size(); ++i) {
        const auto& a = batch[i];
        PixelStats& p = pixels[i];
        for (int c = 0; c < 3; ++c) p.rgb_sum[c] += a.rgb[c];
        p.merge_moments(a.rgb.w, a.lum.x, batch_lum_m2(a));
        p.nonfinite += a.lum.z;
        for (int b = 0; b < 4; ++b) p.bucket_sum[b] += a.bucket0[b];
        for (int b = 0; b < 3; ++b) p.bucket_sum[4 + b] += a.bucket1[b];
        p.glossy_sum += a.bucket1.w;
        p.depth_weighted_sum += a.side.x;
        p.depth_weight += a.side.y;
        if (!direct_glossy_sum.empty()) direct_glossy_sum[i] += a.side.z;  // the variant's; 0 otherwise
    }
}

void Frame::merge(const Frame& other) {
    if (other.width != width || other.height != height || other.pixels.size() != pixels.size())
        throw std::invalid_argument("Frame::merge: a " + std::to_string(other.width) + "x" + std::to_string(other.height) +
                                    " frame merged into a " + std::to_string(width) + "x" + std::to_string(height) + " one");
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
