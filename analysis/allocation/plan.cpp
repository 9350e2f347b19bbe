#include "allocation/plan.hpp"

#include "allocation/mom.hpp"
#include "allocation/neyman.hpp"
#include "render/descriptor.hpp"
#include "stats/summary.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace vkmech {

Pilot make_pilot(Frame frame, std::vector<double> mom_var) {
    Pilot out;
    out.frame = std::move(frame);
    out.seconds = out.frame.seconds;
    out.var.resize(out.frame.pixels.size());
    for (size_t p = 0; p < out.var.size(); ++p) out.var[p] = out.frame.pixels[p].lum_var();
    out.labels = derive_descriptor(out.frame).dominant;
    out.mom_var = std::move(mom_var);
    return out;
}

std::vector<double> mean_rgb(const Frame& f) {
    std::vector<double> out(3 * f.pixels.size());
    for (size_t p = 0; p < f.pixels.size(); ++p) {
        const double n = f.pixels[p].count;
        for (int c = 0; c < 3; ++c) out[3 * p + c] = n > 0 ? f.pixels[p].rgb_sum[c] / n : 0.0;
    }
    return out;
}

std::vector<double> final_image_rgb(const SamplePool& pool, const std::vector<uint32_t>& n) {
    std::vector<double> out(3 * pool.pixels);
    for (size_t p = 0; p < pool.pixels; ++p) {
        double s[3] = {0, 0, 0}, cnt = 0;
        for (uint32_t f = 0; f < n[p]; ++f) {
            const float* x = pool.at(f, p);
            if (x[3] == 0.0f) continue;  // a non-finite sample: counted out, as the renderer does
            s[0] += x[0];
            s[1] += x[1];
            s[2] += x[2];
            cnt += 1;
        }
        for (int c = 0; c < 3; ++c) out[3 * p + c] = cnt > 0 ? s[c] / cnt : 0.0;
    }
    return out;
}

double psnr_peak(const std::vector<double>& rgb) {
    double peak = 0.0;
    for (double v : rgb) peak = std::max(peak, v);
    return peak > 0.0 ? peak : 1.0;  // a black reference: PSNR against peak 1
}

std::vector<double> PilotSamples::mom_variance(int k) const {
    const int size = alloc::mom_block_size(static_cast<int>(samples), k);  // throws for k < 1 or blocks below 2
    std::vector<double> out(pixels, 0.0), block_var;
    for (size_t p = 0; p < pixels; ++p) {
        block_var.clear();
        for (int b = 0; b < k; ++b) {
            alloc::BlockMoments m;
            for (int i = b * size; i < (b + 1) * size; ++i) {
                const float x = lum[static_cast<size_t>(i) * pixels + p];
                if (!std::isnan(x)) alloc::accumulate(m, x);
            }
            if (m.n >= 2) block_var.push_back(m.m2 / (m.n - 1));
        }
        if (!block_var.empty()) out[p] = stats::median(block_var);
    }
    return out;
}

AdaptivePlan plan_allocation(alloc::Strategy s, const alloc::ScoreInputs& in, uint32_t extra_spp, uint32_t floor,
                             uint64_t placebo_seed) {
    auto t0 = std::chrono::steady_clock::now();
    std::vector<double> D = alloc::strategy_score(s, in, placebo_seed);
    AdaptivePlan plan;
    plan.total = alloc::study_total(D.size(), extra_spp);
    plan.n = alloc::neyman_allocation(D, plan.total, floor, downstream_seeds::kPoolSize);
    plan.allocation_ms = 1000.0 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return plan;
}

}  // namespace vkmech
