#include "stats/quantiles.hpp"

#include "stats/summary.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace vkmech::stats {

std::vector<double> quantile_edges(const std::vector<double>& values, int bins) {
    if (bins < 1 || bins > 255) throw std::invalid_argument("stats::quantile_edges: bins must lie in 1..255");
    if (values.empty()) throw std::invalid_argument("stats::quantile_edges: empty sample");
    std::vector<double> sorted = values;
    for (double v : sorted)
        if (std::isnan(v)) throw std::invalid_argument("stats::quantile_edges: NaN value");
    std::sort(sorted.begin(), sorted.end());
    std::vector<double> edges;
    edges.reserve(static_cast<size_t>(bins - 1));
    for (int k = 1; k < bins; ++k) edges.push_back(quantile_sorted(sorted, static_cast<double>(k) / bins));
    return edges;
}

std::vector<uint8_t> quantile_bin(const std::vector<double>& values, const std::vector<double>& edges) {
    if (edges.size() > 254) throw std::invalid_argument("stats::quantile_bin: at most 254 edges");
    if (!std::is_sorted(edges.begin(), edges.end()))
        throw std::invalid_argument("stats::quantile_bin: edges not ascending");
    for (double e : edges)
        if (std::isnan(e)) throw std::invalid_argument("stats::quantile_bin: NaN edge");
    std::vector<uint8_t> out(values.size());
    for (size_t i = 0; i < values.size(); ++i) {
        if (std::isnan(values[i])) throw std::invalid_argument("stats::quantile_bin: NaN value");
        // lower_bound = first edge >= value, so its offset counts edges < value.
        out[i] = static_cast<uint8_t>(std::lower_bound(edges.begin(), edges.end(), values[i]) - edges.begin());
    }
    return out;
}

}  // namespace vkmech::stats
