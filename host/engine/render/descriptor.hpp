// The per-pixel transport-mechanism descriptor derived from a Frame (docs/descriptor.md §3):
// bucket energies L_b, dominant label, purity, glossy_frac, caustic_frac,
// depth, mixed flag, and a scene summary.
#pragma once

#include "render/frame.hpp"

#include <array>
#include <string>
#include <vector>

namespace vkmech {

constexpr uint32_t kBucketCount = gpu::BUCKET_COUNT;
constexpr uint8_t kNoLabel = gpu::NO_LABEL;  // pixels with zero total energy (docs/descriptor.md §3)
extern const std::array<const char*, kBucketCount> kBucketNames;  // docs/descriptor.md §2 names, index order
// Fixed display colour per bucket (sRGB 8-bit), index order.
extern const std::array<std::array<uint8_t, 3>, kBucketCount> kBucketColors;

struct Descriptor {
    int width = 0, height = 0;
    std::vector<std::array<float, kBucketCount>> bucket_energy;  // L_b: mean per-sample energy
    std::vector<uint8_t> dominant;    // argmax_b L_b, ties to the lower index; kNoLabel when sum is 0
    std::vector<float> purity;        // L_dominant / sum_b L_b (0 for unlabelled)
    std::vector<float> glossy_frac;   // gamma
    std::vector<float> caustic_frac;  // L_delta_mediated / sum
    std::vector<float> depth;         // energy-weighted mean n over n >= 1
    std::vector<float> total_energy;  // sum_b L_b
    // docs/descriptor.md §3.4, only when the frame has the split (render --extra-output direct_glossy):
    // the part of L_direct whose events end at a glossy vertex (mean per-sample energy, <= L_direct).
    std::vector<float> direct_glossy;
    // The names of the tally slots in use, in index order: the seven buckets, or a user
    // taxonomy's classes (use_taxonomy_classes), whose last is `other`.
    std::vector<std::string> class_names;
    uint32_t other_class = gpu::BUCKET_OTHER;
    bool taxonomy = false;  // classes of a user taxonomy: caustic_frac (a bucket's share) is not defined
};

// argmax with ties broken to the lower index; kNoLabel when every entry is 0.
uint8_t dominant_bucket(const std::array<double, kBucketCount>& energy);

// A pixel's mean energy in tally slot `slot` over its mean energy in every slot; 0 without energy
// (caustic_frac is delta_mediated's; a taxonomy's class shares are its slots').
double slot_share(const PixelStats& p, uint32_t slot);
// Every slot's share at once (the total summed once): slot_shares(p)[s] == slot_share(p, s).
std::array<double, kBucketCount> slot_shares(const PixelStats& p);

Descriptor derive_descriptor(const Frame& frame);
// Names the slots by a user taxonomy's classes (docs/lpe.md), `other` last; the slots beyond are
// empty. Call before summarize.
void use_taxonomy_classes(Descriptor& d, const std::vector<std::string>& class_names);

struct DescriptorSummary {
    std::array<double, kBucketCount> pixel_share{};   // share of labelled pixels per dominant bucket
    std::array<double, kBucketCount> energy_share{};  // share of total image energy per bucket
    uint64_t labelled_pixels = 0;
    uint64_t nonfinite_samples = 0;
    double other_energy = 0.0;          // absolute energy in `other` (expected 0)
    double max_bucket_sum_error = 0.0;  // max |sum_b L_b - lum_mean| / max(lum_mean, 1e-8)
    // docs/descriptor.md §3.4, when the descriptor has direct_glossy: the image's glossy-ended direct
    // energy as a share of all bucket energy and as a share of the direct bucket's (0 without any).
    bool has_direct_glossy = false;
    double direct_glossy_energy_share = 0.0;
    double direct_glossy_share_of_direct = 0.0;
    std::vector<std::string> class_names;  // Descriptor::class_names
};

DescriptorSummary summarize(const Frame& frame, const Descriptor& d);

}  // namespace vkmech
