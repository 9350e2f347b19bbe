#include "allocation/threshold.hpp"

#include "allocation/guard.hpp"
#include "render/descriptor.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace vkmech::alloc {

std::vector<uint32_t> pixel_samples(const Frame& frame) {
    std::vector<uint32_t> n(frame.pixels.size());
    for (size_t p = 0; p < n.size(); ++p)
        n[p] = static_cast<uint32_t>(frame.pixels[p].count + frame.pixels[p].nonfinite);
    return n;
}

std::vector<double> relative_error(const Frame& frame, Strategy s, const ClassTraits& traits) {
    if (s != Strategy::ObservedVar && s != Strategy::BucketFloor && s != Strategy::Guarded)
        throw std::invalid_argument(
            std::string("a noise threshold's rule is observed-var, bucket-floor or guarded, not ") + to_string(s));
    const size_t P = frame.pixels.size();
    std::vector<double> var(P);
    for (size_t p = 0; p < P; ++p) var[p] = frame.pixels[p].lum_var();
    const std::vector<uint8_t> labels = derive_descriptor(frame).dominant;
    std::vector<uint8_t> untrusted;
    ScoreInputs in;
    in.pilot_var = &var;
    in.pilot_labels = &labels;
    in.heavy = traits.heavy;
    if (s == Strategy::Guarded) {
        untrusted = diagnose_pilot(frame, var, labels, nullptr, traits).untrusted_map;
        in.untrusted = &untrusted;
    }
    const std::vector<double> D = strategy_score(s, in, 0);

    // delta: a fraction of the image's mean luminance over the pixels with finite samples.
    double lum_sum = 0.0;
    size_t lit = 0;
    for (const PixelStats& px : frame.pixels)
        if (px.count > 0.0 && std::isfinite(px.lum_mean)) {
            lum_sum += px.lum_mean;
            ++lit;
        }
    const double delta = lit ? kDarkFloor * lum_sum / static_cast<double>(lit) : 0.0;

    const int W = frame.width, H = frame.height;
    std::vector<double> err(P);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            const size_t p = static_cast<size_t>(y) * W + x;
            const PixelStats& px = frame.pixels[p];
            const double n = px.count + px.nonfinite;
            if (n <= 0.0 || !std::isfinite(D[p])) {
                err[p] = INFINITY;
                continue;
            }
            double mu = std::isfinite(px.lum_mean) ? px.lum_mean : 0.0;
            if (!untrusted.empty() && untrusted[p] != kTrusted)
                for (int v = std::max(0, y - kGuardRadius); v <= std::min(H - 1, y + kGuardRadius); ++v)
                    for (int u = std::max(0, x - kGuardRadius); u <= std::min(W - 1, x + kGuardRadius); ++u) {
                        const double m = frame.pixels[static_cast<size_t>(v) * W + u].lum_mean;
                        if (std::isfinite(m)) mu = std::max(mu, m);
                    }
            const double sd = std::sqrt(std::max(D[p], 0.0) / n);
            err[p] = sd == 0.0 ? 0.0 : sd / (mu + delta);
        }
    return err;
}

std::vector<uint32_t> sample_ladder(uint32_t min_spp, uint32_t max_spp) {
    if (min_spp < 1 || min_spp > max_spp)
        throw std::invalid_argument("the sample ladder needs 1 <= min-spp <= max-spp (min-spp " +
                                    std::to_string(min_spp) + ", max-spp " + std::to_string(max_spp) + ")");
    std::vector<uint32_t> ladder{min_spp};
    while (ladder.back() < max_spp) {
        const double next = std::ceil(static_cast<double>(ladder.back()) * kLadderRatio);
        ladder.push_back(static_cast<uint32_t>(std::min<double>(max_spp, std::max<double>(next, ladder.back() + 1.0))));
    }
    return ladder;
}

namespace {

// The index of n on the ladder; std::invalid_argument when n is not a rung.
size_t rung_of(uint32_t n, const std::vector<uint32_t>& ladder) {
    auto it = std::lower_bound(ladder.begin(), ladder.end(), n);
    if (it == ladder.end() || *it != n)
        throw std::invalid_argument("a pixel has " + std::to_string(n) + " samples, which is not on the sample ladder");
    return static_cast<size_t>(it - ladder.begin());
}

}  // namespace

std::vector<uint32_t> threshold_targets(const std::vector<uint32_t>& n, const std::vector<double>& err,
                                        double threshold, const std::vector<uint32_t>& ladder) {
    if (n.size() != err.size())
        throw std::invalid_argument("threshold_targets: " + std::to_string(n.size()) + " sample counts but " +
                                    std::to_string(err.size()) + " errors");
    std::vector<uint32_t> target(n);
    for (size_t p = 0; p < n.size(); ++p) {
        const size_t r = rung_of(n[p], ladder);
        if (!(err[p] > threshold) || r + 1 == ladder.size()) continue;
        // err falls as 1 / sqrt(n): the need is n (err / T)^2 (infinite for an infinite err).
        const double ratio = err[p] / threshold;
        const double need = static_cast<double>(n[p]) * ratio * ratio;
        const double most = static_cast<double>(n[p]) * kMaxGrowth;
        size_t t = r + 1;
        while (t + 1 < ladder.size() && static_cast<double>(ladder[t]) < need && ladder[t + 1] <= most) ++t;
        target[p] = ladder[t];
    }
    return target;
}

uint64_t fit_round(std::vector<uint32_t>& target, const std::vector<uint32_t>& n, const std::vector<double>& err,
                   const std::vector<uint32_t>& ladder, uint64_t budget) {
    auto total = [&] {
        uint64_t s = 0;
        for (size_t p = 0; p < n.size(); ++p) s += target[p] - n[p];
        return s;
    };
    uint64_t want = total();
    if (want <= budget) return want;
    for (size_t p = 0; p < n.size(); ++p)
        if (target[p] > n[p]) target[p] = ladder[rung_of(n[p], ladder) + 1];
    want = total();
    if (want <= budget) return want;
    std::vector<size_t> order;
    for (size_t p = 0; p < n.size(); ++p)
        if (target[p] > n[p]) order.push_back(p);
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return err[a] > err[b]; });
    uint64_t used = 0;
    for (size_t p : order) {
        const uint64_t step = target[p] - n[p];
        if (used + step <= budget)
            used += step;
        else
            target[p] = n[p];
    }
    return used;
}

}  // namespace vkmech::alloc
