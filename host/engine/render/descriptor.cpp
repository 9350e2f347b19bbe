#include "render/descriptor.hpp"

#include "io/invariant.hpp"

#include <algorithm>
#include <cmath>

namespace vkmech {

const std::array<const char*, kBucketCount> kBucketNames = {
    "emitter_direct", "direct", "diffuse_indirect", "glossy", "delta_mediated", "specular_direct", "other"};

const std::array<std::array<uint8_t, 3>, kBucketCount> kBucketColors = {{
    {255, 221, 87},   // emitter_direct: light yellow
    {86, 180, 233},   // direct: sky blue
    {0, 158, 115},    // diffuse_indirect: green
    {230, 159, 0},    // glossy: orange
    {204, 51, 153},   // delta_mediated: magenta
    {213, 94, 0},     // specular_direct: vermilion
    {128, 128, 128},  // other: grey
}};

uint8_t dominant_bucket(const std::array<double, kBucketCount>& e) {
    uint8_t best = kNoLabel;
    double best_v = 0.0;
    for (uint32_t b = 0; b < kBucketCount; ++b)
        if (e[b] > best_v) {  // strict: ties keep the lower index
            best_v = e[b];
            best = static_cast<uint8_t>(b);
        }
    return best;
}

std::array<double, kBucketCount> slot_shares(const PixelStats& p) {
    std::array<double, kBucketCount> share{};
    if (p.count <= 0) return share;
    double total = 0.0;
    for (uint32_t b = 0; b < kBucketCount; ++b) total += p.bucket_sum[b] / p.count;
    if (total > 0.0)
        for (uint32_t b = 0; b < kBucketCount; ++b) share[b] = p.bucket_sum[b] / p.count / total;
    return share;
}

double slot_share(const PixelStats& p, uint32_t slot) { return slot_shares(p)[slot]; }

Descriptor derive_descriptor(const Frame& f) {
    Descriptor d;
    d.width = f.width;
    d.height = f.height;
    size_t n = f.pixels.size();
    d.bucket_energy.resize(n);
    d.dominant.resize(n);
    d.purity.resize(n);
    d.glossy_frac.resize(n);
    d.caustic_frac.resize(n);
    d.depth.resize(n);
    d.total_energy.resize(n);
    d.class_names.assign(kBucketNames.begin(), kBucketNames.end());
    for (size_t i = 0; i < n; ++i) {
        const PixelStats& p = f.pixels[i];
        std::array<double, kBucketCount> e{};
        double total = 0.0;
        for (uint32_t b = 0; b < kBucketCount; ++b) {
            e[b] = p.count > 0 ? p.bucket_sum[b] / p.count : 0.0;
            total += e[b];
            d.bucket_energy[i][b] = static_cast<float>(e[b]);
        }
        d.total_energy[i] = static_cast<float>(total);
        d.dominant[i] = dominant_bucket(e);
        if (total > 0.0) {
            d.purity[i] = static_cast<float>(e[d.dominant[i]] / total);
            d.glossy_frac[i] = static_cast<float>(std::min(1.0, p.glossy_sum / p.count / total));
            d.caustic_frac[i] = static_cast<float>(slot_share(p, gpu::BUCKET_DELTA_MEDIATED));
        }
        d.depth[i] = p.depth_weight > 0.0 ? static_cast<float>(p.depth_weighted_sum / p.depth_weight) : 0.0f;
    }
    if (f.direct_glossy_sum.size() == n) {
        d.direct_glossy.resize(n);
        for (size_t i = 0; i < n; ++i)
            d.direct_glossy[i] =
                f.pixels[i].count > 0 ? static_cast<float>(f.direct_glossy_sum[i] / f.pixels[i].count) : 0.0f;
    }
    return d;
}

void use_taxonomy_classes(Descriptor& d, const std::vector<std::string>& class_names) {
    VKM_ASSERT(!class_names.empty() && class_names.size() <= kBucketCount,
               "a taxonomy has 1 to " + std::to_string(kBucketCount) + " classes");
    d.class_names = class_names;
    d.other_class = static_cast<uint32_t>(class_names.size()) - 1;
    d.taxonomy = true;
    std::fill(d.caustic_frac.begin(), d.caustic_frac.end(), 0.0f);
}

DescriptorSummary summarize(const Frame& f, const Descriptor& d) {
    DescriptorSummary s;
    s.class_names = d.class_names;
    std::array<double, kBucketCount> energy{};
    double total = 0.0;
    for (size_t i = 0; i < f.pixels.size(); ++i) {
        s.nonfinite_samples += static_cast<uint64_t>(f.pixels[i].nonfinite);
        if (d.dominant[i] != kNoLabel) {
            s.labelled_pixels++;
            s.pixel_share[d.dominant[i]] += 1.0;
        }
        for (uint32_t b = 0; b < kBucketCount; ++b) {
            energy[b] += d.bucket_energy[i][b];
            total += d.bucket_energy[i][b];
        }
        double lum = f.pixels[i].lum_mean;
        double err = std::abs(static_cast<double>(d.total_energy[i]) - lum) / std::max(lum, 1e-8);
        if (lum > 1e-6) s.max_bucket_sum_error = std::max(s.max_bucket_sum_error, err);
    }
    for (uint32_t b = 0; b < kBucketCount; ++b) {
        if (s.labelled_pixels) s.pixel_share[b] /= static_cast<double>(s.labelled_pixels);
        s.energy_share[b] = total > 0 ? energy[b] / total : 0.0;
    }
    s.other_energy = energy[d.other_class];
    if (!d.direct_glossy.empty()) {
        double direct_glossy = 0.0;
        for (float v : d.direct_glossy) direct_glossy += v;
        const double direct = energy[gpu::BUCKET_DIRECT];
        s.has_direct_glossy = true;
        s.direct_glossy_energy_share = total > 0 ? direct_glossy / total : 0.0;
        s.direct_glossy_share_of_direct = direct > 0 ? direct_glossy / direct : 0.0;
    }
    return s;
}

}  // namespace vkmech
