// What the chi-square tests of sampling routines share (test_bsdf.cpp,
// test_environment.cpp): a seeded generator and the chi-square p-value.
#pragma once

#include <cmath>
#include <cstdint>

namespace vkmech::testing {

// SplitMix64: uniform floats in [0, 1) for the sampling tests.
struct TestRng {
    uint64_t s;
    explicit TestRng(uint64_t seed) : s(seed * 0x9E3779B97F4A7C15ull + 0x1234567ull) {}
    uint64_t next_u64() {
        uint64_t z = (s += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    float next() { return static_cast<float>(next_u64() >> 40) * (1.0f / 16777216.0f); }
    double next_double() { return static_cast<double>(next_u64() >> 11) * (1.0 / 9007199254740992.0); }
};

// Regularized upper incomplete gamma Q(a, x) (series / Lentz continued fraction):
// the chi-square p-value of statistic c with k degrees of freedom is Q(k / 2, c / 2).
inline double gamma_q(double a, double x) {
    if (x <= 0.0) return 1.0;
    double lg = -x + a * std::log(x) - std::lgamma(a);
    if (x < a + 1.0) {
        double ap = a, del = 1.0 / a, sum = del;
        for (int n = 0; n < 100000; ++n) {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if (std::abs(del) < std::abs(sum) * 1e-15) break;
        }
        return 1.0 - sum * std::exp(lg);
    }
    const double tiny = 1e-300;
    double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
    for (int i = 1; i < 100000; ++i) {
        double an = -i * (i - a);
        b += 2.0;
        d = an * d + b;
        if (std::abs(d) < tiny) d = tiny;
        c = b + an / c;
        if (std::abs(c) < tiny) c = tiny;
        d = 1.0 / d;
        double del = d * c;
        h *= del;
        if (std::abs(del - 1.0) < 1e-15) break;
    }
    return std::exp(lg) * h;
}

}  // namespace vkmech::testing
