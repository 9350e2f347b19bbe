#include "stats/isotonic.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace vkmech::stats {

std::vector<double> isotonic_increasing(const std::vector<double>& y, const std::vector<double>& w) {
    if (y.size() != w.size()) throw std::invalid_argument("stats::isotonic_increasing: size mismatch");
    for (size_t i = 0; i < y.size(); ++i) {
        if (!(w[i] >= 0.0) || !std::isfinite(w[i]))
            throw std::invalid_argument("stats::isotonic_increasing: weights must be finite and >= 0");
        if (w[i] > 0.0 && !std::isfinite(y[i]))
            throw std::invalid_argument("stats::isotonic_increasing: non-finite y with positive weight");
    }
    // Blocks of consecutive positive-weight entries, merged while the previous
    // block's mean exceeds the last one's (a monotonicity violation).
    struct Block {
        double wy, w;
        size_t n;  // number of positive-weight entries pooled
        double mean() const { return wy / w; }
    };
    std::vector<Block> blocks;
    for (size_t i = 0; i < y.size(); ++i) {
        if (w[i] == 0.0) continue;
        blocks.push_back({w[i] * y[i], w[i], 1});
        while (blocks.size() >= 2 && blocks[blocks.size() - 2].mean() > blocks.back().mean()) {
            Block last = blocks.back();
            blocks.pop_back();
            blocks.back().wy += last.wy;
            blocks.back().w += last.w;
            blocks.back().n += last.n;
        }
    }
    std::vector<double> fit(y.size(), std::numeric_limits<double>::quiet_NaN());
    if (blocks.empty()) return fit;
    // Expand the block means over the positive-weight entries; zero-weight
    // entries take the last fitted value seen (their left neighbour).
    size_t b = 0, used = 0;
    double prev = std::numeric_limits<double>::quiet_NaN();
    for (size_t i = 0; i < y.size(); ++i) {
        if (w[i] == 0.0) {
            fit[i] = prev;
            continue;
        }
        if (used == blocks[b].n) {
            ++b;
            used = 0;
        }
        fit[i] = prev = blocks[b].mean();
        ++used;
    }
    // Leading zero-weight entries have no left neighbour: use the first block.
    for (size_t i = 0; i < y.size() && w[i] == 0.0; ++i) fit[i] = blocks.front().mean();
    return fit;
}

}  // namespace vkmech::stats
