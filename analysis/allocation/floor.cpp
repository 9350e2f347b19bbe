#include "allocation/floor.hpp"

#include "stats/split_half.hpp"
#include "stats/summary.hpp"

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace vkmech::alloc {

std::vector<double> bucket_floor(const std::vector<double>& var, const std::vector<uint8_t>& labels, uint32_t heavy) {
    if (var.size() != labels.size())
        throw std::invalid_argument("alloc::bucket_floor: variance map has " + std::to_string(var.size()) +
                                    " pixels but label map has " + std::to_string(labels.size()));
    std::vector<double> out = var;  // bit-identical copy; only heavy pixels change below

    // Finite variances per heavy label (3, 4, 5 for the paper's buckets).
    std::array<std::vector<double>, 256> per_label;
    bool any_heavy = false;
    for (size_t i = 0; i < var.size(); ++i) {
        if (!is_heavy_tailed(labels[i], heavy)) continue;
        any_heavy = true;
        if (std::isfinite(var[i])) per_label[labels[i]].push_back(var[i]);
    }
    if (!any_heavy) return out;

    std::array<double, 256> med;
    std::array<bool, 256> has_med{};
    for (int b = 0; b < 256; ++b) {
        if (per_label[static_cast<size_t>(b)].empty()) continue;
        med[static_cast<size_t>(b)] = stats::median(std::move(per_label[static_cast<size_t>(b)]));
        has_med[static_cast<size_t>(b)] = true;
    }
    for (size_t i = 0; i < var.size(); ++i) {
        const uint8_t b = labels[i];
        if (!is_heavy_tailed(b, heavy) || !has_med[b] || !std::isfinite(var[i])) continue;
        if (var[i] < med[b]) out[i] = med[b];
    }
    return out;
}

std::vector<uint8_t> placebo_labels(const std::vector<uint8_t>& labels, uint64_t seed) {
    std::vector<uint8_t> out = labels;
    uint64_t state = seed;
    for (size_t i = out.size(); i > 1; --i) {  // Fisher-Yates, from the top: swap slot i-1 with [0, i)
        const size_t j = static_cast<size_t>(stats::uniform_below(state, static_cast<uint64_t>(i)));
        std::swap(out[i - 1], out[j]);
    }
    return out;
}

}  // namespace vkmech::alloc
