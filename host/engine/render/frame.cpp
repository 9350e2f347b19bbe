#include "render/frame.hpp"

#include <cmath>

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
    }
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
