#include "stats/agreement.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

namespace vkmech::stats {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void check_k(int k) {
    if (k < 1 || k > 255) throw std::invalid_argument("stats: class count k must lie in 1..255");
}

void check_label(uint8_t v, int k) {
    if (v != kNoLabel && v >= k)
        throw std::invalid_argument("stats: label " + std::to_string(v) + " outside 0.." + std::to_string(k - 1));
}

size_t idx(int i, int j, int k) { return static_cast<size_t>(i) * static_cast<size_t>(k) + static_cast<size_t>(j); }

// Row sums (map a) and column sums (map b) of the confusion table.
void marginals(const Confusion& c, std::vector<double>& row, std::vector<double>& col) {
    row.assign(c.k, 0.0);
    col.assign(c.k, 0.0);
    for (int i = 0; i < c.k; ++i)
        for (int j = 0; j < c.k; ++j) {
            row[i] += c.at(i, j);
            col[j] += c.at(i, j);
        }
}
}  // namespace

double Confusion::total() const { return std::accumulate(counts.begin(), counts.end(), 0.0); }

Confusion confusion(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int k) {
    check_k(k);
    if (a.size() != b.size()) throw std::invalid_argument("stats::confusion: size mismatch");
    Confusion c;
    c.k = k;
    c.counts.assign(static_cast<size_t>(k) * static_cast<size_t>(k), 0.0);
    for (size_t p = 0; p < a.size(); ++p) {
        check_label(a[p], k);
        check_label(b[p], k);
        if (a[p] == kNoLabel || b[p] == kNoLabel) continue;  // labelled in both only
        c.counts[idx(a[p], b[p], k)] += 1.0;
    }
    return c;
}

uint64_t labelled_in_one_only(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
    if (a.size() != b.size()) throw std::invalid_argument("stats::labelled_in_one_only: size mismatch");
    uint64_t n = 0;
    for (size_t p = 0; p < a.size(); ++p) n += (a[p] == kNoLabel) != (b[p] == kNoLabel);
    return n;
}

double agreement(const Confusion& c) {
    const double n = c.total();
    if (n <= 0.0) return kNaN;
    double tr = 0.0;
    for (int i = 0; i < c.k; ++i) tr += c.at(i, i);
    return tr / n;
}

std::vector<double> pixel_shares(const std::vector<uint8_t>& labels, int k) {
    check_k(k);
    std::vector<double> s(k, 0.0);
    double n = 0.0;
    for (uint8_t v : labels) {
        check_label(v, k);
        if (v == kNoLabel) continue;
        s[v] += 1.0;
        n += 1.0;
    }
    for (double& x : s) x = n > 0.0 ? x / n : kNaN;
    return s;
}

double max_drift(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int k) {
    const auto sa = pixel_shares(a, k), sb = pixel_shares(b, k);
    double m = 0.0;
    for (int i = 0; i < k; ++i) {
        const double d = std::fabs(sa[i] - sb[i]);
        if (std::isnan(d)) return kNaN;  // a map without labelled pixels
        m = std::max(m, d);
    }
    return m;
}

double cohen_kappa(const Confusion& c) {
    // Unit weights on the diagonal, zero elsewhere: the unweighted special case.
    std::vector<double> w(static_cast<size_t>(c.k) * static_cast<size_t>(c.k), 0.0);
    for (int i = 0; i < c.k; ++i) w[idx(i, i, c.k)] = 1.0;
    return weighted_kappa(c, w);
}

double weighted_kappa(const Confusion& c, const std::vector<double>& w) {
    if (w.size() != static_cast<size_t>(c.k) * static_cast<size_t>(c.k))
        throw std::invalid_argument("stats::weighted_kappa: weights must be k*k");
    for (int i = 0; i < c.k; ++i)
        for (int j = 0; j < c.k; ++j) {
            const double v = w[idx(i, j, c.k)];
            if (!(v >= 0.0 && v <= 1.0))
                throw std::invalid_argument("stats::weighted_kappa: weights must lie in [0, 1]");
            if (i == j && v != 1.0) throw std::invalid_argument("stats::weighted_kappa: diagonal weights must be 1");
        }
    const double n = c.total();
    if (n <= 0.0) return kNaN;
    std::vector<double> row, col;
    marginals(c, row, col);
    double po = 0.0, pe = 0.0;
    for (int i = 0; i < c.k; ++i)
        for (int j = 0; j < c.k; ++j) {
            po += w[idx(i, j, c.k)] * c.at(i, j) / n;
            pe += w[idx(i, j, c.k)] * (row[i] / n) * (col[j] / n);
        }
    if (!(1.0 - pe > 0.0)) return kNaN;
    return (po - pe) / (1.0 - pe);
}

std::vector<double> spec_kappa_weights(int k, const std::vector<bool>& light_tailed) {
    check_k(k);
    if (light_tailed.size() != static_cast<size_t>(k))
        throw std::invalid_argument("stats::spec_kappa_weights: light_tailed must have k entries");
    // docs/descriptor.md §5: penalty 0.2 inside the light-tailed family, 1.0 otherwise;
    // agreement weight = 1 - penalty.
    std::vector<double> w(static_cast<size_t>(k) * static_cast<size_t>(k), 0.0);
    for (int i = 0; i < k; ++i)
        for (int j = 0; j < k; ++j) {
            if (i == j)
                w[idx(i, j, k)] = 1.0;
            else if (light_tailed[i] && light_tailed[j])
                w[idx(i, j, k)] = 1.0 - 0.2;
        }
    return w;
}

double structural_share(const Confusion& c, const std::vector<bool>& heavy) {
    if (heavy.size() != static_cast<size_t>(c.k))
        throw std::invalid_argument("stats::structural_share: heavy must have k entries");
    double off = 0.0, touching = 0.0;
    for (int i = 0; i < c.k; ++i)
        for (int j = 0; j < c.k; ++j) {
            if (i == j) continue;
            off += c.at(i, j);
            if (heavy[i] || heavy[j]) touching += c.at(i, j);
        }
    return off > 0.0 ? touching / off : kNaN;
}

}  // namespace vkmech::stats
