// Abstention and guard rails of the adaptive renderer (docs/descriptor.md §6.5):
// what a pilot alone says about where a strategy's assumption fails, and the
// `guarded` score.
//
// Abstention: the bucket floor only acts on pixels whose pilot label is
// heavy-tailed and whose pilot variance lies below its bucket's median. When
// the floor changes no pixel's score (in particular when the pilot has no
// heavy-tailed pixel at all), bucket-floor's score IS observed-var's, bit for
// bit, and so is its allocation; the same holds for robust-floor against
// robust-var. The diagnosis reports it rather than letting the strategy pose
// as a different one.
//
// Untrusted pixels: a pilot-variance strategy gives a pixel whose score is 0
// only the floor of f samples. Two kinds of pixel have such a score although
// the pilot cannot vouch for it (the ajar-door failure mode, where most of
// the scene is lit by a few rare paths and a short pilot sees none of them):
// A pixel is *seen* by the pilot when its lum_mean is not 0 (luminance is
// never negative; a non-finite mean counts as seen) or a sample there was
// counted out as non-finite; *dark* otherwise (every pilot sample was a
// finite 0).
//   - kLitNoVariance: a seen pixel without a usable variance: sigma^2 is 0
//     (fewer than 2 finite samples, or every finite sample equal) or not
//     finite. Exempt: a pixel whose pilot energy is entirely emitter_direct,
//     with at least 2 finite samples and none counted out: an emitter seen
//     directly is constant, and its zero variance is the truth.
//   - kDarkInLitRegion: a dark pixel in a lit region, i.e. whose window of
//     (2 kGuardRadius + 1)^2 = 3 x 3 pixels centred on it, clipped at the
//     image border, holds at least one seen pixel. A black
//     pixel inside or at the edge of a lit area is as likely to be a pixel
//     whose light the pilot missed as a truly black one; the pilot cannot
//     tell. Known price: a truly black background pixel next to a lit
//     silhouette is flagged too (a band one pixel wide), and costs the
//     `guarded` strategy at most its uniform share.
#pragma once

#include "allocation/floor.hpp"
#include "allocation/plan.hpp"
#include "render/frame.hpp"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vkmech::alloc {

inline constexpr int kGuardRadius = 1;  // the lit-region window is 3 x 3

// Per-pixel codes of PilotDiagnosis::untrusted (0: trusted).
inline constexpr uint8_t kTrusted = 0;
inline constexpr uint8_t kLitNoVariance = 1;
inline constexpr uint8_t kDarkInLitRegion = 2;

struct PilotDiagnosis {
    size_t pixels = 0;
    size_t labelled = 0;  // pilot label != NO_LABEL (the pixels the reliability curve speaks of)
    size_t seen = 0;      // seen pixels (above)

    // Abstention of the floor.
    size_t heavy = 0;             // pixels with a heavy-tailed pilot label
    size_t floor_changed = 0;     // pixels where bucket_floor(sigma^2, labels) differs from sigma^2 (bits)
    bool floor_abstains = true;   // floor_changed == 0: bucket-floor == observed-var bit for bit
    bool robust_checked = false;  // a median-of-means variance was given
    size_t robust_floor_changed = 0;
    bool robust_floor_abstains = true;  // robust-floor == robust-var bit for bit (when robust_checked)

    // Untrusted pixels.
    size_t lit_no_variance = 0;
    size_t dark_in_lit_region = 0;
    size_t untrusted = 0;                // the sum of the two
    std::vector<uint8_t> untrusted_map;  // per pixel: kTrusted, kLitNoVariance or kDarkInLitRegion

    double untrusted_share() const { return pixels ? static_cast<double>(untrusted) / pixels : 0.0; }
};

// The diagnosis of a pilot from the pilot alone: its frame (per-pixel moments,
// bucket sums, counts), its variance sigma^2 and labels (one per pixel), and
// optionally the median-of-means variance (nullptr or empty: robust-floor not
// checked). Throws std::invalid_argument if the sizes differ from the frame's
// width * height. `traits`: which classes are heavy-tailed (the floor) and constant (the
// emitter-seen-directly exemption above, for which `emitter_direct` stands in the paper's buckets).
PilotDiagnosis diagnose_pilot(const Frame& frame, const std::vector<double>& var, const std::vector<uint8_t>& labels,
                              const std::vector<double>* mom_var = nullptr, const ClassTraits& traits = {});
PilotDiagnosis diagnose_pilot(const Pilot& pilot, const ClassTraits& traits = {});

// The `guarded` score from the bucket-floor score D0 and the untrusted map
// (nonzero: untrusted). Trusted pixels keep D0 bit for bit; with no untrusted
// pixel the result is D0 exactly. Untrusted pixel u gets
//   D(u) = max(D0(u), w^2)   (w^2 alone when D0(u) is not finite),
// where w is the mean Neyman weight of the result: with s(p) = sqrt(D0(p)) for
// finite D0(p) > 0 and 0 otherwise (as neyman_allocation weighs them), w is the
// unique solution of
//   w = (sum over trusted s(p) + sum over untrusted max(s(u), w)) / P.
// An untrusted pixel's weight is then at least the mean weight, so its Neyman
// share is at least the uniform share total / P (to the rounding of one
// sample), whatever the floor; the total is unchanged (Neyman allocation).
// If every pixel is untrusted, D = 1 everywhere (uniform).
// Throws std::invalid_argument if the sizes differ.
std::vector<double> guard_score(std::vector<double> D0, const std::vector<uint8_t>& untrusted);

}  // namespace vkmech::alloc
