#include "allocation/neyman.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace vkmech::alloc {

std::vector<uint32_t> neyman_allocation(const std::vector<double>& D, uint64_t total, uint32_t floor, uint32_t cap,
                                        size_t* nonfinite) {
    const size_t P = D.size();
    if (floor > cap)
        throw std::invalid_argument("alloc::neyman_allocation: floor " + std::to_string(floor) + " exceeds cap " +
                                    std::to_string(cap));
    const uint64_t lo = static_cast<uint64_t>(floor) * P;
    const uint64_t hi = static_cast<uint64_t>(cap) * P;
    if (total < lo || total > hi)
        throw std::invalid_argument("alloc::neyman_allocation: total " + std::to_string(total) +
                                    " outside [floor * P, cap * P] = [" + std::to_string(lo) + ", " +
                                    std::to_string(hi) + "] for P = " + std::to_string(P));

    // Weights sqrt(max(D, 0)), normalised by the largest so sums stay in [0, P].
    size_t bad = 0;
    std::vector<double> w(P, 0.0);
    double wmax = 0.0;
    for (size_t i = 0; i < P; ++i) {
        if (!std::isfinite(D[i])) {
            ++bad;
            continue;
        }
        w[i] = std::sqrt(std::max(D[i], 0.0));
        wmax = std::max(wmax, w[i]);
    }
    if (nonfinite) *nonfinite = bad;
    if (P == 0) return {};
    if (wmax > 0.0)
        for (double& v : w) v /= wmax;

    // Water-filling of the real targets x.
    const double f = static_cast<double>(floor);
    const double c = static_cast<double>(cap);
    std::vector<double> x(P, f);
    std::vector<char> capped(P, 0);
    size_t n_capped = 0;
    for (;;) {
        const double R = static_cast<double>(total - lo) - static_cast<double>(n_capped) * (c - f);
        double W = 0.0;
        for (size_t i = 0; i < P; ++i)
            if (!capped[i]) W += w[i];
        const size_t active = P - n_capped;
        if (active == 0) break;
        bool any_over = false;
        for (size_t i = 0; i < P; ++i) {
            if (capped[i]) continue;
            const double share = W > 0.0 ? R * w[i] / W : R / static_cast<double>(active);
            x[i] = f + std::max(share, 0.0);
            if (x[i] > c) any_over = true;
        }
        if (!any_over) break;
        for (size_t i = 0; i < P; ++i) {
            if (!capped[i] && x[i] > c) {
                capped[i] = 1;
                x[i] = c;
                ++n_capped;
            }
        }
    }

    // Largest remainder.
    std::vector<uint32_t> n(P);
    std::vector<double> frac(P);
    uint64_t sum = 0;
    for (size_t i = 0; i < P; ++i) {
        const double fl = std::floor(x[i]);
        uint64_t v = static_cast<uint64_t>(fl);
        v = std::clamp<uint64_t>(v, floor, cap);
        n[i] = static_cast<uint32_t>(v);
        frac[i] = x[i] - static_cast<double>(v);
        sum += v;
    }
    std::vector<size_t> order(P);
    std::iota(order.begin(), order.end(), size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return frac[a] > frac[b]; });
    // Missing samples: one each by descending remainder, ties to the lower
    // index (stable sort over ascending indices). Repeated passes only occur
    // under floating-point error; total <= cap * P makes them terminate.
    while (sum < total) {
        for (size_t k = 0; k < P && sum < total; ++k) {
            const size_t i = order[k];
            if (n[i] < cap) {
                ++n[i];
                ++sum;
            }
        }
    }
    // Excess (floating-point error only): remove from the smallest remainders,
    // the higher index first; total >= floor * P makes this terminate.
    while (sum > total) {
        for (size_t k = P; k-- > 0 && sum > total;) {
            const size_t i = order[k];
            if (n[i] > floor) {
                --n[i];
                --sum;
            }
        }
    }
    return n;
}

}  // namespace vkmech::alloc
