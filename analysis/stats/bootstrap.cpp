#include "stats/bootstrap.hpp"

#include "stats/rank.hpp"
#include "stats/summary.hpp"

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

namespace vkmech::stats {

namespace {

// The argument checks both bootstraps share (sizes, width, tile, resamples, level).
void check_arguments(const std::string& what, size_t size_a, size_t size_b, int width, int tile, int resamples,
                     double level) {
    if (size_a != size_b) throw std::invalid_argument(what + ": the two maps have different sizes");
    if (width < 1 || tile < 1) throw std::invalid_argument(what + ": width and tile must be at least 1");
    if (size_a % static_cast<size_t>(width) != 0)
        throw std::invalid_argument(what + ": the map size is not a multiple of the width");
    if (resamples < 10) throw std::invalid_argument(what + ": at least 10 resamples");
    if (!(level > 0.0 && level < 1.0)) throw std::invalid_argument(what + ": level must be in (0, 1)");
}

}  // namespace

Interval tile_bootstrap(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int k, int width, int tile,
                        const std::function<double(const Confusion&)>& statistic, int resamples, uint64_t seed,
                        double level) {
    check_arguments("tile_bootstrap", a.size(), b.size(), width, tile, resamples, level);
    const Confusion whole = confusion(a, b, k);  // validates the labels
    const size_t h = a.size() / static_cast<size_t>(width);
    const size_t tx = (static_cast<size_t>(width) + tile - 1) / tile, ty = (h + tile - 1) / tile;
    const size_t kk = static_cast<size_t>(k) * k;
    std::vector<double> tiles(tx * ty * kk, 0.0);  // each tile's confusion counts
    for (size_t y = 0; y < h; ++y)
        for (size_t x = 0; x < static_cast<size_t>(width); ++x) {
            const size_t i = y * width + x;
            if (a[i] == kNoLabel || b[i] == kNoLabel) continue;
            tiles[((y / tile) * tx + x / tile) * kk + static_cast<size_t>(a[i]) * k + b[i]] += 1.0;
        }
    const size_t n = tx * ty;
    std::mt19937_64 rng(seed);
    std::vector<double> scores;
    scores.reserve(static_cast<size_t>(resamples));
    Confusion c = whole;
    for (int r = 0; r < resamples; ++r) {
        std::fill(c.counts.begin(), c.counts.end(), 0.0);
        for (size_t j = 0; j < n; ++j) {
            const size_t t = static_cast<size_t>(((rng() >> 32) * n) >> 32);  // uniform in [0, n)
            const double* src = &tiles[t * kk];
            for (size_t q = 0; q < kk; ++q) c.counts[q] += src[q];
        }
        const double s = statistic(c);
        if (std::isfinite(s)) scores.push_back(s);
    }
    if (scores.empty()) return {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
    const double alpha = (1.0 - level) / 2.0;
    return {quantile(scores, alpha), quantile(scores, 1.0 - alpha)};
}

Interval tile_bootstrap_spearman(const std::vector<double>& x, const std::vector<double>& y, int width, int tile,
                                 int resamples, uint64_t seed, double level) {
    check_arguments("tile_bootstrap_spearman", x.size(), y.size(), width, tile, resamples, level);
    const size_t h = x.size() / static_cast<size_t>(width);
    const size_t tx = (static_cast<size_t>(width) + tile - 1) / tile, ty = (h + tile - 1) / tile;
    std::vector<std::vector<size_t>> tiles(tx * ty);  // the kept pixels of each tile
    for (size_t yy = 0; yy < h; ++yy)
        for (size_t xx = 0; xx < static_cast<size_t>(width); ++xx) {
            const size_t i = yy * width + xx;
            if (std::isnan(x[i]) || std::isnan(y[i])) continue;
            tiles[(yy / tile) * tx + xx / tile].push_back(i);
        }
    const size_t n = tiles.size();
    std::mt19937_64 rng(seed);
    std::vector<double> scores, rx, ry;
    scores.reserve(static_cast<size_t>(resamples));
    for (int r = 0; r < resamples; ++r) {
        rx.clear();
        ry.clear();
        for (size_t j = 0; j < n; ++j) {
            const size_t t = static_cast<size_t>(((rng() >> 32) * n) >> 32);  // uniform in [0, n)
            for (size_t i : tiles[t]) {
                rx.push_back(x[i]);
                ry.push_back(y[i]);
            }
        }
        const double s = rx.size() >= 2 ? spearman(rx, ry) : std::numeric_limits<double>::quiet_NaN();
        if (std::isfinite(s)) scores.push_back(s);
    }
    if (scores.empty()) return {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::quiet_NaN()};
    const double alpha = (1.0 - level) / 2.0;
    return {quantile(scores, alpha), quantile(scores, 1.0 - alpha)};
}

}  // namespace vkmech::stats
