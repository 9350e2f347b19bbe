#include "allocation/guard.hpp"

#include "allocation/floor.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>

namespace vkmech::alloc {

namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

// Pixels where the floor's output differs, bit for bit, from its input.
size_t changed_by_floor(const std::vector<double>& var, const std::vector<uint8_t>& labels, uint32_t heavy) {
    const std::vector<double> floored = bucket_floor(var, labels, heavy);
    size_t n = 0;
    for (size_t p = 0; p < var.size(); ++p) n += same_bits(floored[p], var[p]) ? 0 : 1;
    return n;
}

bool seen(const PixelStats& s) { return s.lum_mean != 0.0 || s.nonfinite > 0.0; }

// All of the pilot's energy at the pixel is in the constant classes (the paper's emitter_direct: a
// light seen directly), and there is some.
bool constant_only(const PixelStats& s, uint32_t constant) {
    double in_constant = 0.0;
    for (uint32_t b = 0; b < gpu::BUCKET_COUNT; ++b) {
        if (((constant >> b) & 1u) == 0) {
            if (s.bucket_sum[b] != 0.0) return false;
        } else {
            in_constant += s.bucket_sum[b];
        }
    }
    return in_constant > 0.0;
}

void check_size(size_t got, size_t want, const char* what) {
    if (got != want)
        throw std::invalid_argument(std::string("alloc::diagnose_pilot: ") + what + " has " + std::to_string(got) +
                                    " pixels, the frame " + std::to_string(want));
}

}  // namespace

PilotDiagnosis diagnose_pilot(const Frame& frame, const std::vector<double>& var, const std::vector<uint8_t>& labels,
                              const std::vector<double>* mom_var, const ClassTraits& traits) {
    const size_t P = frame.pixels.size();
    if (static_cast<size_t>(frame.width) * static_cast<size_t>(frame.height) != P)
        throw std::invalid_argument("alloc::diagnose_pilot: the frame is " + std::to_string(frame.width) + " x " +
                                    std::to_string(frame.height) + " but holds " + std::to_string(P) + " pixels");
    check_size(var.size(), P, "the variance map");
    check_size(labels.size(), P, "the label map");
    const bool robust = mom_var && !mom_var->empty();
    if (robust) check_size(mom_var->size(), P, "the median-of-means variance map");

    PilotDiagnosis d;
    d.pixels = P;
    for (size_t p = 0; p < P; ++p) {
        d.labelled += labels[p] != gpu::NO_LABEL ? 1 : 0;
        d.heavy += is_heavy_tailed(labels[p], traits.heavy) ? 1 : 0;
        d.seen += seen(frame.pixels[p]) ? 1 : 0;
    }
    d.floor_changed = changed_by_floor(var, labels, traits.heavy);
    d.floor_abstains = d.floor_changed == 0;
    if (robust) {
        d.robust_checked = true;
        d.robust_floor_changed = changed_by_floor(*mom_var, labels, traits.heavy);
        d.robust_floor_abstains = d.robust_floor_changed == 0;
    }

    d.untrusted_map.assign(P, kTrusted);
    const int W = frame.width, H = frame.height;
    for (int y = 0; y < H; ++y) {
        for (int x = 0; x < W; ++x) {
            const size_t p = static_cast<size_t>(y) * W + x;
            const PixelStats& s = frame.pixels[p];
            if (seen(s)) {
                const bool usable = std::isfinite(var[p]) && var[p] != 0.0;
                const bool constant_light =
                    std::isfinite(var[p]) && s.count >= 2.0 && s.nonfinite == 0.0 && constant_only(s, traits.constant);
                if (!usable && !constant_light) d.untrusted_map[p] = kLitNoVariance;
                continue;
            }
            bool lit_region = false;
            for (int v = std::max(0, y - kGuardRadius); v <= std::min(H - 1, y + kGuardRadius) && !lit_region; ++v)
                for (int u = std::max(0, x - kGuardRadius); u <= std::min(W - 1, x + kGuardRadius); ++u)
                    if (seen(frame.pixels[static_cast<size_t>(v) * W + u])) {
                        lit_region = true;
                        break;
                    }
            if (lit_region) d.untrusted_map[p] = kDarkInLitRegion;
        }
    }
    for (uint8_t c : d.untrusted_map) {
        d.lit_no_variance += c == kLitNoVariance ? 1 : 0;
        d.dark_in_lit_region += c == kDarkInLitRegion ? 1 : 0;
    }
    d.untrusted = d.lit_no_variance + d.dark_in_lit_region;
    return d;
}

PilotDiagnosis diagnose_pilot(const Pilot& pilot, const ClassTraits& traits) {
    return diagnose_pilot(pilot.frame, pilot.var, pilot.labels, &pilot.mom_var, traits);
}

std::vector<double> guard_score(std::vector<double> D0, const std::vector<uint8_t>& untrusted) {
    if (D0.size() != untrusted.size())
        throw std::invalid_argument("alloc::guard_score: score map has " + std::to_string(D0.size()) +
                                    " pixels but untrusted map has " + std::to_string(untrusted.size()));
    const size_t P = D0.size();
    // Neyman's weight of a score (neyman.hpp: non-finite and negative D count as 0).
    auto weight = [](double d) { return std::isfinite(d) && d > 0.0 ? std::sqrt(d) : 0.0; };
    double trusted_sum = 0.0;
    std::vector<double> a;  // the untrusted pixels' own weights
    for (size_t p = 0; p < P; ++p) {
        if (untrusted[p])
            a.push_back(weight(D0[p]));
        else
            trusted_sum += weight(D0[p]);
    }
    if (a.empty()) return D0;
    if (a.size() == P) return std::vector<double>(P, 1.0);

    // Water level: with the m largest untrusted weights kept and the others
    // raised to w, w = (trusted_sum + sum of the m kept) / (P - k + m); the
    // first m whose next weight does not exceed that w is the solution (each
    // candidate is a weighted mean of the previous one and a weight above it,
    // so the kept weights stay above w).
    std::sort(a.begin(), a.end(), std::greater<double>());
    const size_t k = a.size();
    double kept = 0.0, w = 0.0;
    for (size_t m = 0; m <= k; ++m) {
        w = (trusted_sum + kept) / static_cast<double>(P - k + m);
        if (m == k || a[m] <= w) break;
        kept += a[m];
    }
    const double level = w * w;
    for (size_t p = 0; p < P; ++p) {
        if (!untrusted[p]) continue;
        if (!std::isfinite(D0[p]) || D0[p] < level) D0[p] = level;
    }
    return D0;
}

}  // namespace vkmech::alloc
