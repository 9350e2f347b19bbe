#include "allocation/mom.hpp"

#include "stats/summary.hpp"

#include <stdexcept>
#include <string>

namespace vkmech::alloc {

void accumulate(BlockMoments& m, double x) {
    m.n += 1.0;
    const double d = x - m.mean;
    m.mean += d / m.n;
    m.m2 += d * (x - m.mean);
}

std::vector<double> mom_variance(const std::vector<std::vector<BlockMoments>>& blocks) {
    if (blocks.empty()) throw std::invalid_argument("alloc::mom_variance: no blocks");
    const size_t pixels = blocks.front().size();
    for (size_t b = 0; b < blocks.size(); ++b) {
        if (blocks[b].size() != pixels)
            throw std::invalid_argument("alloc::mom_variance: block " + std::to_string(b) + " has " +
                                        std::to_string(blocks[b].size()) + " pixels, block 0 has " +
                                        std::to_string(pixels));
    }
    std::vector<double> out(pixels);
    std::vector<double> v;
    v.reserve(blocks.size());
    for (size_t p = 0; p < pixels; ++p) {
        v.clear();
        for (size_t b = 0; b < blocks.size(); ++b) {
            const BlockMoments& m = blocks[b][p];
            if (m.n >= 2.0) v.push_back(m.m2 / (m.n - 1.0));  // a block left with < 2 finite samples is dropped
        }
        out[p] = v.empty() ? 0.0 : stats::median(v);
    }
    return out;
}

int mom_block_count(int n0) {
    if (n0 < 1) throw std::invalid_argument("alloc::mom_block_count: N0 must be >= 1, got " + std::to_string(n0));
    int k = 1;
    while (static_cast<long long>(k) * k < n0) ++k;
    return k;
}

int mom_block_size(int n0) {
    const int k = mom_block_count(n0);
    const int size = n0 / k;
    if (size < 3)
        throw std::invalid_argument("median-of-means needs blocks of at least 3 samples; N0 = " + std::to_string(n0) +
                                    " gives " + std::to_string(k) + " blocks of " + std::to_string(size) +
                                    ": not defined");
    return size;
}

bool mom_defined(int n0) {
    if (n0 < 1) return false;
    return n0 / mom_block_count(n0) >= 3;
}

int mom_discarded(int n0) { return n0 - mom_block_count(n0) * mom_block_size(n0); }

int mom_block_size(int n0, int k) {
    if (n0 < 1) throw std::invalid_argument("alloc::mom_block_size: N0 must be >= 1, got " + std::to_string(n0));
    if (k < 1) throw std::invalid_argument("alloc::mom_block_size: k must be >= 1, got " + std::to_string(k));
    const int size = n0 / k;
    if (size < 2)
        throw std::invalid_argument(
            "median-of-means needs blocks of at least 2 samples for a ddof-1 variance; N0 = " + std::to_string(n0) +
            " with k = " + std::to_string(k) + " gives blocks of " + std::to_string(size) + ": not defined");
    return size;
}

int mom_discarded(int n0, int k) { return n0 - k * mom_block_size(n0, k); }

}  // namespace vkmech::alloc
