#include "stats/split_half.hpp"

#include <algorithm>
#include <limits>
#include <numeric>
#include <set>
#include <stdexcept>

namespace vkmech::stats {

uint64_t splitmix64_next(uint64_t& state) {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

uint64_t uniform_below(uint64_t& state, uint64_t bound) {
    if (bound == 0) throw std::invalid_argument("stats::uniform_below: bound must be >= 1");
    // 2^64 mod bound: outputs below it would make the low residues more likely.
    const uint64_t threshold = (0 - bound) % bound;
    for (;;) {
        const uint64_t r = splitmix64_next(state);
        if (r >= threshold) return r % bound;
    }
}

uint64_t distinct_half_splits(int n) {
    if (n < 2 || n % 2 != 0) throw std::invalid_argument("stats::distinct_half_splits: n must be even and >= 2");
    const uint64_t kMax = std::numeric_limits<uint64_t>::max();
    const uint64_t h = static_cast<uint64_t>(n / 2);
    // C(n, i+1) = C(n, i) * (n - i) / (i + 1); the product is divisible exactly.
    uint64_t c = 1;
    for (uint64_t i = 0; i < h; ++i) {
        const uint64_t m = static_cast<uint64_t>(n) - i;
        if (c > kMax / m) return kMax;
        c = c * m / (i + 1);
    }
    return c / 2;
}

std::vector<Partition> random_halves(int n, int count, uint64_t base_seed) {
    if (n < 2 || n % 2 != 0) throw std::invalid_argument("stats::random_halves: n must be even and >= 2");
    if (count < 0) throw std::invalid_argument("stats::random_halves: count must be >= 0");
    if (static_cast<uint64_t>(count) > distinct_half_splits(n))
        throw std::invalid_argument("stats::random_halves: more partitions requested than distinct splits exist");
    uint64_t state = base_seed;
    std::set<std::vector<int>> seen;  // canonical key: the half holding index 0
    std::vector<Partition> out;
    std::vector<int> perm(static_cast<size_t>(n));
    while (out.size() < static_cast<size_t>(count)) {
        std::iota(perm.begin(), perm.end(), 0);
        for (size_t i = perm.size() - 1; i > 0; --i) {  // Fisher-Yates, from the top
            const size_t j = static_cast<size_t>(uniform_below(state, i + 1));
            std::swap(perm[i], perm[j]);
        }
        Partition p;
        p.a.assign(perm.begin(), perm.begin() + n / 2);
        p.b.assign(perm.begin() + n / 2, perm.end());
        std::sort(p.a.begin(), p.a.end());
        std::sort(p.b.begin(), p.b.end());
        const std::vector<int>& key = p.a.front() == 0 ? p.a : p.b;
        if (!seen.insert(key).second) continue;  // same unordered pair as before
        out.push_back(std::move(p));
    }
    return out;
}

}  // namespace vkmech::stats
