#include "experiments/allocation_data.hpp"

#include "allocation/allocation.hpp"
#include "render/descriptor.hpp"
#include "shared/types.h"
#include "stats/summary.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace vkmech::allocation_data {

double lum_of(double r, double g, double b) { return gpu::LUM_R * r + gpu::LUM_G * g + gpu::LUM_B * b; }

alloc::ScoreInputs pilot_inputs(const SceneData& d, const SamplePool& pool, uint32_t n0, uint32_t k) {
    const Pilot& pl = d.pilots.at(n0)[k];
    alloc::ScoreInputs in;
    in.pilot_var = &pl.var;
    in.pilot_labels = &pl.labels;
    in.oracle_var = &pool.oracle_var;
    in.reference_labels = &d.ref_labels;
    if (!pl.mom_var.empty()) in.mom_var = &pl.mom_var;
    in.untrusted = &d.diagnoses.at(n0)[k].untrusted_map;
    in.pilot_spp = n0;
    in.heavy = d.traits.heavy;
    in.rare = d.traits.rare;
    return in;
}

Errors evaluate(const SceneData& d, const SamplePool& pool, const std::vector<uint32_t>& n) {
    std::vector<double> lum(d.P), pixel_se(d.P);
    double se = 0, rel = 0, se_clamped = 0, se_p999 = 0;
    std::array<double, kBucketCount> bse{}, bn{};
    const std::vector<double> img = final_image_rgb(pool, n);
    for (size_t p = 0; p < d.P; ++p) {
        const double* v = &img[3 * p];
        double e = 0;
        for (int c = 0; c < 3; ++c) {
            const double r = d.ref_rgb[3 * p + c];
            const double diff = v[c] - r;
            e += diff * diff / 3.0;
            rel += diff * diff / (r * r + 1e-2) / 3.0;
            const double dc = std::clamp(v[c], 0.0, 1.0) - d.ref_rgb_clamped[3 * p + c];
            se_clamped += dc * dc / 3.0;
            const double dq = std::min(v[c], d.p999) - d.ref_rgb_p999[3 * p + c];
            se_p999 += dq * dq / 3.0;
        }
        lum[p] = lum_of(v[0], v[1], v[2]);
        pixel_se[p] = e;
        se += e;
        if (d.ref_labels[p] != kNoLabel) {
            bse[d.ref_labels[p]] += e;
            bn[d.ref_labels[p]] += 1;
        }
    }
    Errors out;
    out.mse = se / d.P;
    out.rel_mse = rel / d.P;
    out.mse_clamped = se_clamped / d.P;
    out.mse_p999 = se_p999 / d.P;
    out.median_se = stats::median(std::move(pixel_se));
    out.p99 = alloc::p99_abs_error(lum, d.ref_lum);
    for (uint32_t b = 0; b < kBucketCount; ++b) out.bucket_mse[b] = bn[b] > 0 ? bse[b] / bn[b] : NAN;
    return out;
}

namespace {
void check_pool(const SamplePool& pool, const SceneData& d, const SceneVariant& scene, uint32_t index) {
    if (pool.pixels != d.P || pool.frames < downstream_seeds::kPoolSize)
        throw std::runtime_error("allocation study: " + (index ? downstream_seeds::pool_label(index) : "the pool") +
                                 " of " + scene.name + " has " + std::to_string(pool.frames) + " frames of " +
                                 std::to_string(pool.pixels) + " pixels; the reference has " + std::to_string(d.P) +
                                 " pixels and " + std::to_string(downstream_seeds::kPoolSize) + " frames are needed");
}
}  // namespace

SceneData load_scene_data(AllocationSource& source, const StudyConfig& cfg, const SceneVariant& scene) {
    SceneData d;
    const Frame ref = source.reference(scene);
    d.w = ref.width;
    d.h = ref.height;
    d.P = static_cast<size_t>(d.w) * d.h;
    // The mean over all samples taken (a non-finite one counts out, as in the final images).
    d.ref_rgb = mean_rgb(ref);
    d.ref_rgb_clamped.resize(3 * d.P);
    d.ref_lum.resize(d.P);
    for (size_t i = 0; i < 3 * d.P; ++i) d.ref_rgb_clamped[i] = std::clamp(d.ref_rgb[i], 0.0, 1.0);
    for (size_t p = 0; p < d.P; ++p)
        d.ref_lum[p] = lum_of(d.ref_rgb[3 * p], d.ref_rgb[3 * p + 1], d.ref_rgb[3 * p + 2]);
    d.peak = psnr_peak(d.ref_rgb);
    d.p999 = stats::quantile(d.ref_rgb, 0.999);
    d.ref_rgb_p999.resize(3 * d.P);
    for (size_t i = 0; i < 3 * d.P; ++i) d.ref_rgb_p999[i] = std::min(d.ref_rgb[i], d.p999);
    d.ref_labels = derive_descriptor(ref).dominant;
    d.class_names = source.class_names(scene);
    d.traits = source.class_traits(scene);

    d.pool = source.pool(scene, 0);
    check_pool(d.pool, d, scene, 0);
    const uint32_t K = static_cast<uint32_t>(cfg.alloc_draws);
    for (uint32_t n0 : cfg.alloc_pilots)
        for (uint32_t k = 0; k < K; ++k) {
            Pilot p = source.pilot(scene, n0, k);
            if (p.var.size() != d.P)
                throw std::runtime_error("allocation study: pilot " + std::to_string(k) + " of " + scene.name +
                                         " has " + std::to_string(p.var.size()) + " pixels, not " +
                                         std::to_string(d.P));
            d.diagnoses[n0].push_back(alloc::diagnose_pilot(p, d.traits));
            d.pilots[n0].push_back(std::move(p));
        }
    return d;
}

SamplePool load_pool(AllocationSource& source, const SceneData& d, const SceneVariant& scene, uint32_t index) {
    SamplePool pool = source.pool(scene, index);
    check_pool(pool, d, scene, index);
    return pool;
}

}  // namespace vkmech::allocation_data
